// The exported Gaussian PLY read back by a reader of its own (header and
// binary rows, as a 3DGS loader reads them), posed with its own weights and
// rendered through fskin's ops: it matches the avatar's render.
#include "fskin/gaussians/gaussian_export.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cstring>
#include <map>
#include <sstream>

#include "fskin/util/atomic_file.h"
#include "fskin/skeleton/rotations.h"
#include "gaussians/exported_gaussians.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

// A binary little-endian PLY of float / int properties: each element's rows
// as float64 [count, properties] and its property names; the comments.
struct Ply {
  std::map<std::string, std::vector<std::string>> properties;
  std::map<std::string, torch::Tensor> rows;
  std::vector<std::string> comments;
  torch::Tensor column(const std::string& element, const std::string& name) const {
    const auto& names = properties.at(element);
    for (size_t k = 0; k < names.size(); ++k)
      if (names[k] == name) return rows.at(element).select(1, static_cast<int64_t>(k));
    ADD_FAILURE() << "no property " << name;
    return {};
  }
};

Ply read_ply(const std::string& path) {
  const std::string bytes = read_file(path);
  const auto end = bytes.find("end_header\n");
  EXPECT_NE(end, std::string::npos);
  std::istringstream header(bytes.substr(0, end));
  std::string line;
  std::getline(header, line);
  EXPECT_EQ(line, "ply");
  std::getline(header, line);
  EXPECT_EQ(line, "format binary_little_endian 1.0");
  Ply ply;
  std::vector<std::pair<std::string, int64_t>> elements;
  std::map<std::string, std::vector<std::string>> types;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "comment") {
      ply.comments.push_back(line.substr(8));
    } else if (word == "element") {
      std::string name;
      int64_t count = 0;
      words >> name >> count;
      elements.push_back({name, count});
    } else if (word == "property") {
      std::string type, name;
      words >> type >> name;
      types[elements.back().first].push_back(type);
      ply.properties[elements.back().first].push_back(name);
    }
  }
  size_t offset = end + std::strlen("end_header\n");
  for (const auto& [name, count] : elements) {
    const auto& element_types = types[name];
    auto rows = torch::empty({count, static_cast<int64_t>(element_types.size())}, torch::kFloat64);
    auto r = rows.accessor<double, 2>();
    for (int64_t i = 0; i < count; ++i) {
      for (size_t k = 0; k < element_types.size(); ++k) {
        EXPECT_TRUE(element_types[k] == "float" || element_types[k] == "int") << element_types[k];
        if (element_types[k] == "float") {
          float v;
          std::memcpy(&v, bytes.data() + offset, 4);
          r[i][static_cast<int64_t>(k)] = v;
        } else {
          int32_t v;
          std::memcpy(&v, bytes.data() + offset, 4);
          r[i][static_cast<int64_t>(k)] = v;
        }
        offset += 4;
      }
    }
    ply.rows[name] = rows;
  }
  EXPECT_EQ(offset, bytes.size());
  return ply;
}

TEST(GaussianExport, ThePlyPosedWithItsOwnWeightsRendersAsTheAvatar) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  const auto split = dataset.load_split("train");
  auto avatar = testing::varied_gaussian_avatar(dataset.character(), 2000, 2);  // every parameter matters
  const auto path = (testing::temp_dir("gaussian_export") / "avatar.ply").string();
  const auto bones = split.bone_transforms.narrow(0, 0, 3);
  write_gaussian_ply(path, *avatar, dataset.character().skeleton, bones, 24);
  const Ply ply = read_ply(path);

  const int64_t n = 2000, joints = dataset.character().num_joints();
  ASSERT_EQ(ply.rows.at("vertex").size(0), n);
  const auto column = [&](const std::string& name) { return ply.column("vertex", name).to(torch::kFloat32); };
  const auto columns = [&](const std::string& prefix, int64_t count) {
    std::vector<torch::Tensor> out;
    for (int64_t k = 0; k < count; ++k) out.push_back(column(prefix + std::to_string(k)));
    return torch::stack(out, 1);
  };
  const auto means = torch::stack({column("x"), column("y"), column("z")}, 1);
  const auto scales = torch::exp(columns("scale_", 3));
  const auto rotations = columns("rot_", 4);
  const auto opacities = torch::sigmoid(column("opacity"));
  // 3DGS's layout: f_dc, then f_rest channel by channel.
  const auto dc = columns("f_dc_", 3).unsqueeze(1);
  const auto rest = columns("f_rest_", 24).view({n, 3, 8}).transpose(1, 2);
  const auto sh = torch::cat({dc, rest}, 1);
  const auto weights = columns("weight_", joints);
  EXPECT_TRUE(torch::allclose(weights.sum(1), torch::ones({n}), 1e-4, 1e-4));
  // The skeleton and the animation.
  ASSERT_EQ(ply.rows.at("joint").size(0), joints);
  EXPECT_EQ(ply.column("joint", "parent")[1].item<double>(),
            static_cast<double>(dataset.character().skeleton.parents[1]));
  EXPECT_NE(std::find(ply.comments.begin(), ply.comments.end(),
                      "joint_name 0 " + dataset.character().skeleton.joint_names[0]),
            ply.comments.end());
  EXPECT_NE(std::find(ply.comments.begin(), ply.comments.end(), "fps 24"), ply.comments.end());
  const auto animation = ply.rows.at("bone_transform").to(torch::kFloat32).view({3, joints, 4, 4});
  EXPECT_TRUE(torch::equal(animation, bones));

  for (int64_t frame = 0; frame < 3; ++frame) {
    const auto& camera = split.cameras[static_cast<size_t>(frame)];
    // Posed as the PLY's documentation says, by the tests' own code.
    const bool antialiased =
        std::find(ply.comments.begin(), ply.comments.end(), "antialiased") != ply.comments.end();
    EXPECT_EQ(antialiased, avatar->options().antialiased);
    const auto dilation_line = std::find_if(ply.comments.begin(), ply.comments.end(),
                                            [](const std::string& c) { return c.rfind("dilation ", 0) == 0; });
    ASSERT_NE(dilation_line, ply.comments.end());
    const double dilation = std::stod(dilation_line->substr(9));
    EXPECT_EQ(dilation, avatar->options().dilation);
    const testing::FileGaussians file{means, quaternion_to_matrix(rotations / rotations.norm(2, 1, true)),
                                      scales, opacities, sh, weights, antialiased, dilation};
    SCOPED_TRACE("frame " + std::to_string(frame));
    testing::expect_renders_as_avatar(file, animation[frame], *avatar, bones[frame], camera, 1e-3);
  }
}

TEST(GaussianExport, BadInputsAreNamed) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  GaussianAvatarOptions options;
  options.initial_gaussians = 10;
  options.skinning_grid_resolution = 16;
  GaussianAvatar avatar(dataset.character(), options, 0);
  const auto dir = testing::temp_dir("gaussian_export_bad");
  testing::expect_error(
      [&] {
        write_gaussian_ply((dir / "a.ply").string(), *avatar, dataset.character().skeleton,
                           torch::eye(4).expand({2, 3, 4, 4}));
      },
      {"a.ply", "bone transforms"});
  testing::expect_error(
      [&] { write_gaussian_ply((dir / "b.ply").string(), *avatar, dataset.character().skeleton, {}, 0); },
      {"b.ply", "fps"});
}

}  // namespace
}  // namespace fskin
