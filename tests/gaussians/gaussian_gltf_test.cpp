// The Gaussian avatar's glTF (KHR_gaussian_splatting, skinned, animated) read
// back by this test's own code on tinygltf's parse: the extension's
// attributes decoded as its text defines them, the joints' global matrices
// evaluated from the node tree and the animation's keyframes, the Gaussians
// posed with the file's own weights and rendered through fskin's ops: they
// match the avatar's render.
#include "fskin/gaussians/gaussian_gltf.h"

#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <torch/torch.h>

#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>

#include "fskin/skeleton/rotations.h"
#include "fskin/util/atomic_file.h"
#include "gaussians/exported_gaussians.h"
#include "radiance/tiny_image_dataset.h"

namespace fskin {
namespace {

// Accessor `index` of float32 or uint16 components as float64 [count, components].
torch::Tensor read_accessor(const tinygltf::Model& model, int index) {
  const auto& accessor = model.accessors.at(static_cast<size_t>(index));
  const auto& view = model.bufferViews.at(static_cast<size_t>(accessor.bufferView));
  const auto& buffer = model.buffers.at(static_cast<size_t>(view.buffer));
  const int components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(accessor.type));
  const int size = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(accessor.componentType));
  const size_t stride = view.byteStride ? view.byteStride : static_cast<size_t>(components * size);
  auto out = torch::empty({static_cast<int64_t>(accessor.count), components}, torch::kFloat64);
  auto o = out.accessor<double, 2>();
  for (size_t i = 0; i < accessor.count; ++i) {
    const unsigned char* row = buffer.data.data() + view.byteOffset + accessor.byteOffset + i * stride;
    for (int c = 0; c < components; ++c) {
      if (accessor.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT) {
        float v;
        std::memcpy(&v, row + c * size, sizeof v);
        o[static_cast<int64_t>(i)][c] = v;
      } else {
        EXPECT_EQ(accessor.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
        uint16_t v;
        std::memcpy(&v, row + c * size, sizeof v);
        o[static_cast<int64_t>(i)][c] = v;
      }
    }
  }
  return out;
}

// A unit quaternion (x, y, z, w) as a rotation matrix, as the extension writes it out.
torch::Tensor rotation_from_xyzw(const torch::Tensor& q) {
  return quaternion_to_matrix(torch::stack({q.select(-1, 3), q.select(-1, 0), q.select(-1, 1), q.select(-1, 2)}, -1));
}

// Skinning matrices [J, 4, 4] (global joint matrix x inverse bind matrix) at keyframe `frame`.
torch::Tensor skinning_matrices(const tinygltf::Model& model, int64_t frame) {
  const auto& skin = model.skins.at(0);
  const auto& clip = model.animations.at(0);
  const int64_t joints = static_cast<int64_t>(skin.joints.size());
  std::vector<torch::Tensor> local(model.nodes.size());
  for (size_t k = 0; k < model.nodes.size(); ++k) {
    const auto& node = model.nodes[k];
    auto m = torch::eye(4, torch::kFloat64);
    if (!node.translation.empty()) m.narrow(0, 0, 3).select(1, 3).copy_(torch::tensor(node.translation));
    if (!node.rotation.empty()) m.narrow(0, 0, 3).narrow(1, 0, 3).copy_(rotation_from_xyzw(torch::tensor(node.rotation)));
    local[k] = m;
  }
  for (const auto& channel : clip.channels) {
    const auto values = read_accessor(model, clip.samplers.at(static_cast<size_t>(channel.sampler)).output)[frame];
    auto& m = local.at(static_cast<size_t>(channel.target_node));
    if (channel.target_path == "translation") m.narrow(0, 0, 3).select(1, 3).copy_(values);
    if (channel.target_path == "rotation") m.narrow(0, 0, 3).narrow(1, 0, 3).copy_(rotation_from_xyzw(values));
  }
  std::vector<torch::Tensor> global(model.nodes.size());
  const std::function<void(int, const torch::Tensor&)> walk = [&](int k, const torch::Tensor& parent) {
    global[static_cast<size_t>(k)] = torch::matmul(parent, local[static_cast<size_t>(k)]);
    for (int child : model.nodes[static_cast<size_t>(k)].children) walk(child, global[static_cast<size_t>(k)]);
  };
  for (int root : model.scenes.at(0).nodes) walk(root, torch::eye(4, torch::kFloat64));
  // Column-major in the file.
  const auto inverse_bind = read_accessor(model, skin.inverseBindMatrices).view({joints, 4, 4}).transpose(1, 2);
  std::vector<torch::Tensor> out;
  for (int64_t j = 0; j < joints; ++j)
    out.push_back(torch::matmul(global.at(static_cast<size_t>(skin.joints[j])), inverse_bind[j]));
  return torch::stack(out);
}

TEST(GaussianGltf, TheFilePosedWithItsOwnSkinRendersAsTheAvatar) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  const auto split = dataset.load_split("train");
  auto avatar = testing::varied_gaussian_avatar(dataset.character(), 2000, 2);  // every parameter matters
  const auto path = (testing::temp_dir("gaussian_gltf") / "avatar.glb").string();
  GaussianExportOptions gltf;
  gltf.bones = split.bone_transforms.narrow(0, 0, 3);
  gltf.fps = 24;
  gltf.influences = 0;  // every weight: the file poses exactly as the avatar
  write_gaussian_gltf(path, *avatar, dataset.character().skeleton, gltf);

  tinygltf::Model model;
  std::string error, warning;
  ASSERT_TRUE(tinygltf::TinyGLTF().LoadBinaryFromFile(&model, &error, &warning, path)) << error;
  ASSERT_EQ(model.extensionsUsed, std::vector<std::string>{"KHR_gaussian_splatting"});
  const auto& primitive = model.meshes.at(0).primitives.at(0);
  EXPECT_EQ(primitive.mode, TINYGLTF_MODE_POINTS);
  const auto& extension = primitive.extensions.at("KHR_gaussian_splatting");
  EXPECT_EQ(extension.Get("kernel").Get<std::string>(), "ellipse");
  EXPECT_EQ(extension.Get("colorSpace").Get<std::string>(), "srgb_rec709_display");
  const bool antialiased = primitive.extras.Get("fskin").Get("antialiased").Get<bool>();
  EXPECT_EQ(antialiased, avatar->options().antialiased);
  const double dilation = primitive.extras.Get("fskin").Get("dilation").GetNumberAsDouble();
  EXPECT_EQ(dilation, avatar->options().dilation);
  const auto attribute = [&](const std::string& name) {
    EXPECT_TRUE(primitive.attributes.count(name)) << name;
    return read_accessor(model, primitive.attributes.at(name)).to(torch::kFloat32);
  };
  const std::string k = "KHR_gaussian_splatting:";
  const int64_t n = 2000, joints = dataset.character().num_joints();
  const auto means = attribute("POSITION");
  ASSERT_EQ(means.size(0), n);
  const auto rotation_xyzw = attribute(k + "ROTATION");
  EXPECT_TRUE(torch::allclose(rotation_xyzw.norm(2, 1), torch::ones({n}), 1e-5, 1e-5));  // unit, as required
  const auto scales = attribute(k + "SCALE");
  EXPECT_GT(scales.min().item<double>(), 0.0);  // linear, not logs
  const auto opacities = attribute(k + "OPACITY").squeeze(1);
  EXPECT_TRUE(((opacities > 0) & (opacities < 1)).all().item<bool>());
  std::vector<torch::Tensor> coefficients;
  for (int64_t l = 0; l <= 2; ++l)
    for (int64_t c = 0; c <= 2 * l; ++c)
      coefficients.push_back(attribute(k + "SH_DEGREE_" + std::to_string(l) + "_COEF_" + std::to_string(c)));
  EXPECT_FALSE(primitive.attributes.count(k + "SH_DEGREE_3_COEF_0"));
  const auto sh = torch::stack(coefficients, 1);  // [N, 9, 3]
  const auto fallback = attribute("COLOR_0");
  EXPECT_TRUE(torch::allclose(fallback.select(1, 3), opacities));
  // The skin: every joint's weight in sets of four.
  auto weights = torch::zeros({n, joints}, torch::kFloat32);
  for (int set = 0; primitive.attributes.count("JOINTS_" + std::to_string(set)); ++set) {
    const auto ids = attribute("JOINTS_" + std::to_string(set)).to(torch::kInt64);
    weights.scatter_add_(1, ids, attribute("WEIGHTS_" + std::to_string(set)));
  }
  EXPECT_TRUE(torch::allclose(weights.sum(1), torch::ones({n}), 1e-4, 1e-4));
  ASSERT_EQ(model.animations.size(), 1u);
  const auto times = read_accessor(model, model.animations[0].samplers.at(0).input);
  EXPECT_NEAR(times[2][0].item<double>(), 2.0 / 24, 1e-6);

  for (int64_t frame = 0; frame < 3; ++frame) {
    const auto& camera = split.cameras[static_cast<size_t>(frame)];
    const auto bones = skinning_matrices(model, frame).to(torch::kFloat32);
    EXPECT_LT((bones - gltf.bones[frame]).abs().max().item<double>(), 1e-4) << "frame " << frame;
    const testing::FileGaussians file{means, rotation_from_xyzw(rotation_xyzw), scales, opacities, sh, weights,
                                      antialiased, dilation};
    SCOPED_TRACE("frame " + std::to_string(frame));
    testing::expect_renders_as_avatar(file, bones, *avatar, split.bone_transforms[frame], camera, 2e-3);
  }
}

TEST(GaussianGltf, FourInfluencesAndBadInputs) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  GaussianAvatarOptions options;
  options.initial_gaussians = 50;
  GaussianAvatar avatar(dataset.character(), options, 0);
  const auto dir = testing::temp_dir("gaussian_gltf_bad");
  const auto path = (dir / "four.gltf").string();
  write_gaussian_gltf(path, *avatar, dataset.character().skeleton);  // the default: four influences, no animation
  tinygltf::Model model;
  std::string error, warning;
  ASSERT_TRUE(tinygltf::TinyGLTF().LoadASCIIFromFile(&model, &error, &warning, path)) << error;
  const auto& attributes = model.meshes.at(0).primitives.at(0).attributes;
  EXPECT_TRUE(attributes.count("JOINTS_0"));
  EXPECT_FALSE(attributes.count("JOINTS_1"));
  EXPECT_TRUE(model.animations.empty());
  EXPECT_EQ(model.skins.at(0).joints.size(), static_cast<size_t>(dataset.character().num_joints()));
  testing::expect_error(
      [&] {
        GaussianExportOptions bad;
        bad.bones = torch::eye(4).expand({2, 3, 4, 4});
        write_gaussian_gltf((dir / "a.glb").string(), *avatar, dataset.character().skeleton, bad);
      },
      {"a.glb", "bone transforms"});
  testing::expect_error(
      [&] { write_gaussian_gltf((dir / "b.obj").string(), *avatar, dataset.character().skeleton); }, {"b.obj"});
  testing::expect_error(
      [&] {
        GaussianExportOptions bad;
        bad.fps = 0;
        write_gaussian_gltf((dir / "c.glb").string(), *avatar, dataset.character().skeleton, bad);
      },
      {"c.glb", "fps"});
}

TEST(GaussianGltf, PassesTheKhronosValidatorAndLoadsInThreeJs) {
  const ImageDataset dataset(testing::tiny_image_dataset().dir);
  GaussianAvatarOptions options;
  options.initial_gaussians = 300;
  options.sh_degree = 3;
  GaussianAvatar avatar(dataset.character(), options, 1);
  const auto dir = testing::temp_dir("gaussian_gltf_check");
  const auto glb = (dir / "avatar.glb").string(), gltf = (dir / "avatar.gltf").string();
  const auto log = (dir / "check.log").string();
  GaussianExportOptions file;
  file.bones = dataset.load_split("train").bone_transforms.narrow(0, 0, 2);
  write_gaussian_gltf(glb, *avatar, dataset.character().skeleton, file);
  file.influences = 0;
  write_gaussian_gltf(gltf, *avatar, dataset.character().skeleton, file);
  const std::string command = "node " + std::string(FSKIN_GLTF_CHECK) + " " + glb + " " + gltf + " > " + log + " 2>&1";
  const int status = std::system(command.c_str());
  const std::string output = read_file(log);
  ASSERT_EQ(status, 0) << output << "\n(scripts/setup.sh installs node and the checkers)";
  EXPECT_NE(output.find("\"errors\":0,\"warnings\":0"), std::string::npos) << output;
  EXPECT_NE(output.find("\"points\":300"), std::string::npos) << output;
  EXPECT_NE(output.find("\"clips\":1"), std::string::npos) << output;
}

}  // namespace
}  // namespace fskin
