#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/image_dataset_builder.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "fskin/io/npz.h"
#include "fskin/radiance/surface_texture.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"
#include "tiny_image_dataset.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

TEST(ImageDataset, HasTheSplitsOfTheLayout) {
  const auto& tiny = testing::tiny_image_dataset();
  const ImageDataset data(tiny.dir);
  EXPECT_EQ(data.split_names(), image_split_names());
  const auto train = data.load_split("train");
  EXPECT_EQ(train.size(), 3 * 2);
  EXPECT_EQ(train.images.sizes(), (std::vector<int64_t>{6, 40, 40, 3}));
  EXPECT_EQ(data.load_split("novel_view").size(), 2);
  const auto novel_pose = data.load_split("novel_pose");
  EXPECT_EQ(novel_pose.size(), 2);
  // Held-out views are not training views.
  EXPECT_GE(novel_pose.view_index.min().item<int64_t>(), 2);
  EXPECT_LE(train.view_index.max().item<int64_t>(), 1);
  // PeopleSnapshot's files.
  for (const char* file : {"train/cameras.npz", "train/poses.npz", "train/images/image_0000.png",
                           "train/masks/mask_0005.png", "canonical.npz", "manifest.json"})
    EXPECT_TRUE(fs::exists(fs::path(tiny.dir) / file)) << file;
  const io::NpzReader cameras((fs::path(tiny.dir) / "train" / "cameras.npz").string());
  EXPECT_EQ(cameras.tensor("intrinsic").sizes(), (std::vector<int64_t>{6, 3, 3}));
  EXPECT_EQ(cameras.tensor("extrinsic").sizes(), (std::vector<int64_t>{6, 4, 4}));
  EXPECT_EQ(cameras.tensor("height").item<int64_t>(), 40);
}

TEST(ImageDataset, MasksCoverTheProjectedPosedSurface) {
  const auto& tiny = testing::tiny_image_dataset();
  const ImageDataset data(tiny.dir);
  const auto split = data.load_split("novel_pose");
  const auto& character = data.character();
  for (int64_t i = 0; i < split.size(); ++i) {
    // The posed vertices by LBS with the stored bones: each projects onto a covered pixel.
    const auto posed = linear_blend_skinning(character.mesh.vertices.unsqueeze(0), character.weights,
                                             split.bone_transforms[i].unsqueeze(0))[0];
    int64_t inside = 0, total = 0;
    for (int64_t v = 0; v < posed.size(0); v += 7) {
      const Eigen::Vector3d p(posed[v][0].item<double>(), posed[v][1].item<double>(), posed[v][2].item<double>());
      const Eigen::Vector2d uv = split.cameras[i].project(p);
      const auto u = static_cast<int64_t>(std::lround(uv.x())), w = static_cast<int64_t>(std::lround(uv.y()));
      ASSERT_TRUE(u >= 0 && u < 40 && w >= 0 && w < 40) << "vertex " << v << " projects outside the image";
      // Silhouette vertices may round onto the uncovered neighbour of a pixel.
      const auto near = split.masks[i].slice(0, std::max<int64_t>(w - 1, 0), w + 2).slice(1, std::max<int64_t>(u - 1, 0), u + 2);
      inside += near.max().item<uint8_t>() > 0;
      ++total;
    }
    EXPECT_GT(static_cast<double>(inside) / total, 0.995) << "image " << i;
    // Background pixels are the dataset's background (white), subject pixels are not all white.
    const auto background = split.masks[i] == 0;
    EXPECT_TRUE(split.images[i].index({background}).eq(255).all().item<bool>());
    EXPECT_LT(split.images[i].index({split.masks[i] == 255}).to(torch::kFloat32).mean().item<float>(), 230);
  }
}

TEST(ImageDataset, RebuildingSkipsFinishedImagesAndRefusesOtherParameters) {
  const auto& tiny = testing::tiny_image_dataset();
  const auto again = build_image_dataset(tiny.model, tiny.poses, tiny.held_out, tiny.options);
  EXPECT_EQ(again.images_written, 0);
  EXPECT_EQ(again.images_skipped, 10);
  auto other = tiny.options;
  other.width = 48;
  testing::expect_error([&] { build_image_dataset(tiny.model, tiny.poses, tiny.held_out, other); },
                        {tiny.dir, "different"});
}

TEST(ImageDataset, PosesNewPosesLikeItsOwnFrames) {
  const auto& tiny = testing::tiny_image_dataset();
  const auto model_path = testing::temp_dir("image_dataset_model") / "model.npz";
  tiny.model.save(model_path.string());
  const ImageDataset data(tiny.dir);
  const auto novel_pose = data.load_split("novel_pose");
  const auto bones = data.bone_transforms(tiny.held_out, "held out", model_path.string());
  EXPECT_TRUE(torch::allclose(bones, novel_pose.bone_transforms, 1e-5, 1e-5));
  CharacterOptions other;
  other.resolution = 40;
  other.height = 1.2;
  const auto other_path = model_path.parent_path() / "other.npz";
  make_character_model(other).save(other_path.string());
  testing::expect_error([&] { data.bone_transforms(tiny.held_out, "held out", other_path.string()); },
                        {other_path.string(), "not the body model"});
}

TEST(ImageDataset, BadFilesAreNamed) {
  const auto& tiny = testing::tiny_image_dataset();
  const auto dir = testing::temp_dir("image_dataset_bad");
  fs::copy(tiny.dir, dir, fs::copy_options::recursive);
  // A camera that is no rotation.
  {
    const io::NpzReader cameras((dir / "train" / "cameras.npz").string());
    io::NpzWriter writer;
    auto extrinsic = cameras.tensor("extrinsic").clone();
    extrinsic[2] = extrinsic[2] * 3;
    extrinsic[2][3][3] = 1;
    writer.add("intrinsic", cameras.tensor("intrinsic"));
    writer.add("extrinsic", extrinsic);
    writer.add("height", cameras.tensor("height"));
    writer.add("width", cameras.tensor("width"));
    writer.save((dir / "train" / "cameras.npz").string());
  }
  const ImageDataset data(dir.string());
  testing::expect_error([&] { data.load_split("train"); }, {"cameras.npz: camera 2", "rotation"});
  // A missing image.
  fs::remove(dir / "novel_view" / "images" / "image_0001.png");
  testing::expect_error([&] { data.load_split("novel_view"); }, {"image_0001.png", "missing"});
  // A mask of another size.
  write_file_atomically((dir / "novel_pose" / "masks" / "mask_0000.png").string(),
                        read_file((dir / "novel_pose" / "images" / "image_0000.png").string()).substr(0, 40));
  testing::expect_error([&] { data.load_split("novel_pose"); }, {"mask_0000.png"});
  testing::expect_error([&] { data.load_split("test"); }, {"no split 'test'"});
  testing::expect_error([&] { ImageDataset((dir / "nothing").string()); }, {"manifest.json", "missing"});
}

TEST(ImageDataset, MalformedCamerasCharactersAndSplitsAreNamed) {
  const auto& tiny = testing::tiny_image_dataset();
  const auto dir = testing::temp_dir("image_dataset_malformed");
  fs::copy(tiny.dir, dir, fs::copy_options::recursive);
  const auto rewrite = [](const fs::path& path, const std::string& key, const torch::Tensor& value) {
    const io::NpzReader in(path.string());
    io::NpzWriter out;
    for (const auto& k : in.keys()) {
      if (k == key) out.add(k, value);
      else if (k == "joint_names") out.add_strings(k, in.strings(k));
      else out.add(k, in.tensor(k));
    }
    out.save(path.string());
  };
  const auto cameras = dir / "train" / "cameras.npz";
  rewrite(cameras, "intrinsic", torch::eye(2, torch::kFloat64));
  testing::expect_error([&] { load_cameras(cameras.string(), -1); }, {cameras.string(), "intrinsic", "[2, 2]"});
  rewrite(cameras, "intrinsic", torch::eye(3, torch::kFloat64));
  rewrite(cameras, "width", torch::tensor({1e30}));
  testing::expect_error([&] { load_cameras(cameras.string(), -1); }, {cameras.string(), "1..16384"});

  const auto canonical = dir / "canonical.npz";
  const auto parents = io::NpzReader(canonical.string()).tensor("parents").clone();
  auto cycle = parents.clone();
  cycle[1] = 2;  // joint 1's parent is a later joint
  rewrite(canonical, "parents", cycle);
  testing::expect_error([&] { ImageDataset{dir.string()}; }, {canonical.string(), "joint 1 has parent 2"});
  rewrite(canonical, "parents", parents);
  rewrite(canonical, "joints", io::NpzReader(canonical.string()).tensor("joints") * 1e30);
  testing::expect_error([&] { ImageDataset{dir.string()}; }, {canonical.string(), "joints", "implausible"});
  fs::copy_file(tiny.dir + "/canonical.npz", canonical, fs::copy_options::overwrite_existing);

  const auto manifest_path = dir / "manifest.json";
  auto manifest = nlohmann::json::parse(read_file(manifest_path.string()));
  manifest["splits"].push_back("../../elsewhere");
  write_file_atomically(manifest_path.string(), manifest.dump());
  testing::expect_error([&] { ImageDataset{dir.string()}; },
                        {manifest_path.string(), "'../../elsewhere'", "not a directory name inside the dataset"});
}

TEST(ImageDataset, MonocularHasOneCameraAndATurningSubject) {
  const auto& tiny = testing::tiny_image_dataset();
  const auto dir = testing::temp_dir("image_dataset_monocular");
  auto options = testing::tiny_image_options(dir.string());
  options.monocular = true;
  options.width = options.height = 24;
  const auto poses = tiny.poses.slice(0, 1).poses.expand({4, -1, -1}).contiguous();
  const PoseSet same_pose{poses, torch::zeros({4, 3}), tiny.poses.joint_names};
  build_image_dataset(tiny.model, same_pose, PoseSet{}, options);
  const io::NpzReader cameras((dir / "train" / "cameras.npz").string());
  EXPECT_EQ(cameras.tensor("intrinsic").sizes(), (std::vector<int64_t>{3, 3}));  // PeopleSnapshot's one camera
  const ImageDataset data(dir.string());
  const auto train = data.load_split("train");
  ASSERT_EQ(train.size(), 4);
  EXPECT_EQ(data.load_split("novel_pose").size(), 0);
  // The same pose turned by 0, 90, 180, 270 degrees about +Y: the root's rotations differ by those.
  for (int64_t i = 1; i < 4; ++i) {
    const auto relative = train.bone_transforms[i][0].slice(0, 0, 3).slice(1, 0, 3).matmul(
        train.bone_transforms[0][0].slice(0, 0, 3).slice(1, 0, 3).transpose(0, 1));
    const double angle = std::atan2(relative[0][2].item<double>(), relative[0][0].item<double>());
    const double expected = std::remainder(M_PI / 2 * static_cast<double>(i), 2 * M_PI);
    EXPECT_NEAR(std::remainder(angle - expected, 2 * M_PI), 0.0, 1e-4) << i;
    EXPECT_NEAR(relative[1][1].item<double>(), 1.0, 1e-5);
  }
  // Different pictures of one pose.
  EXPECT_FALSE(torch::equal(train.images[0], train.images[1]));
}

TEST(ImageDataset, ALightShadesTheSurfaceAsItFacesTheLight) {
  const auto& tiny = testing::tiny_image_dataset();
  const auto dir = testing::temp_dir("image_dataset_lit");
  auto options = testing::tiny_image_options(dir.string());
  options.light = {0.0, 1.0, 0.0};  // from above
  options.ambient = 0.2;
  build_image_dataset(tiny.model, tiny.poses, tiny.held_out, options);
  const auto manifest = nlohmann::json::parse(read_file((dir / "manifest.json").string()));
  EXPECT_EQ(manifest.at("light"), nlohmann::json({0.0, 1.0, 0.0}));
  EXPECT_DOUBLE_EQ(manifest.at("ambient").get<double>(), 0.2);
  const auto lit = ImageDataset(dir.string()).load_split("train");
  const auto unlit = ImageDataset(tiny.dir).load_split("train");
  // Same silhouettes; the subject no brighter anywhere, and darker on the whole.
  EXPECT_TRUE(torch::equal(lit.masks, unlit.masks));
  const auto subject = (unlit.masks == 255).unsqueeze(-1).expand_as(unlit.images);
  const auto lit_subject = lit.images.masked_select(subject).to(torch::kFloat32);
  const auto unlit_subject = unlit.images.masked_select(subject).to(torch::kFloat32);
  EXPECT_LE((lit_subject - unlit_subject).max().item<double>(), 1.0);
  EXPECT_LT(lit_subject.mean().item<double>(), 0.9 * unlit_subject.mean().item<double>());
  // Surfaces facing away keep the ambient share, those facing the light nearly all.
  const auto ratio = lit_subject / unlit_subject.clamp_min(40);
  EXPECT_LT(ratio.min().item<double>(), 0.35);
  EXPECT_GT(ratio.max().item<double>(), 0.9);
  auto bad = options;
  bad.ambient = 1.5;
  testing::expect_error([&] { build_image_dataset(tiny.model, tiny.poses, tiny.held_out, bad); }, {"ambient"});
}

TEST(ImageDataset, LightThatChangesScalesEachTrainingPoseAndLeavesNovelPoses) {
  const auto& tiny = testing::tiny_image_dataset();
  const auto dir = testing::temp_dir("image_dataset_light_change");
  auto options = testing::tiny_image_options(dir.string());
  options.light_change = 0.3;
  build_image_dataset(tiny.model, tiny.poses, tiny.held_out, options);
  const auto manifest = nlohmann::json::parse(read_file((dir / "manifest.json").string()));
  EXPECT_DOUBLE_EQ(manifest.at("light_change").get<double>(), 0.3);
  const ImageDataset changed(dir.string()), plain(tiny.dir);
  // The per-channel factor of each image: the subject's mean over the plain
  // render's, where neither is clamped (below 250).
  const auto factors = [](const ImageSplit& a, const ImageSplit& b) {
    std::vector<std::array<double, 3>> out;
    for (int64_t i = 0; i < a.size(); ++i) {
      std::array<double, 3> f{};
      for (int c = 0; c < 3; ++c) {
        const auto x = a.images[i].select(2, c).to(torch::kFloat64), y = b.images[i].select(2, c).to(torch::kFloat64);
        const auto use = (b.masks[i] == 255) & (x < 250) & (y > 40);
        f[c] = (x.masked_select(use).sum() / y.masked_select(use).sum()).item<double>();
      }
      out.push_back(f);
    }
    return out;
  };
  for (const auto& name : {"train", "novel_view", "novel_pose"}) {
    const auto a = changed.load_split(name), b = plain.load_split(name);
    EXPECT_TRUE(torch::equal(a.masks, b.masks)) << name;
    const auto f = factors(a, b);
    for (int64_t i = 0; i < a.size(); ++i) {
      for (int c = 0; c < 3; ++c) {
        if (std::string(name) == "novel_pose") {
          EXPECT_NEAR(f[i][c], 1.0, 0.01) << name << " " << i;  // novel poses keep the plain light
        } else {
          EXPECT_GT(f[i][c], 0.69) << name << " " << i;
          EXPECT_LT(f[i][c], 1.31) << name << " " << i;
        }
      }
    }
    if (std::string(name) == "novel_pose") continue;
    // Every view of a pose shares its factors; the poses' differ.
    for (int64_t i = 0; i < a.size(); ++i)
      for (int64_t j = 0; j < a.size(); ++j)
        if (a.pose_index[i].item<int64_t>() == a.pose_index[j].item<int64_t>())
          for (int c = 0; c < 3; ++c) EXPECT_NEAR(f[i][c], f[j][c], 0.02) << name << " " << i << " " << j;
  }
  const auto train = changed.load_split("train");
  const auto f = factors(train, plain.load_split("train"));
  double spread = 0;
  for (const auto& row : f)
    for (int c = 0; c < 3; ++c) spread = std::max(spread, std::abs(row[c] - f[0][c]));
  EXPECT_GT(spread, 0.02);
  auto bad = options;
  bad.light_change = 1.0;
  testing::expect_error([&] { build_image_dataset(tiny.model, tiny.poses, tiny.held_out, bad); }, {"light change"});
}

TEST(SurfaceTexture, GivesEveryRigDetailAndTheSmplCharacterAFace) {
  const auto& tiny = testing::tiny_image_dataset();
  const ImageDataset data(tiny.dir);
  const auto& c = data.character();
  const auto& vertices = c.mesh.vertices;
  const SurfaceTexture texture(vertices, c.weights, c.skeleton.joint_names);
  const auto colours = texture.vertex_colors(vertices, c.weights).to(torch::kFloat32);
  // Many distinct colours (parts, patterns, seams, face), none outside [0, 255].
  EXPECT_GT(std::get<0>(torch::_unique(colours.select(1, 0) * 65536 + colours.select(1, 1) * 256 + colours.select(1, 2))).numel(), 20);
  // The same texture from the same input.
  EXPECT_TRUE(torch::equal(texture.vertex_colors(vertices, c.weights), texture.vertex_colors(vertices, c.weights)));
  // Any other rig (names that are not SMPL's): colours per bone with patterns, no face.
  std::vector<std::string> names;
  for (int64_t j = 0; j < c.num_joints(); ++j) names.push_back("bone." + std::to_string(j));
  const SurfaceTexture generic(vertices * 30, c.weights, names);  // 51 m tall
  const auto generic_colours = generic.vertex_colors(vertices * 30, c.weights).to(torch::kFloat32);
  EXPECT_GT(std::get<0>(torch::_unique(generic_colours.select(1, 0) * 65536 + generic_colours.select(1, 1) * 256 +
                                       generic_colours.select(1, 2)))
                .numel(),
            10);
  testing::expect_error([&] { SurfaceTexture(vertices, c.weights, {"a", "b"}); }, {"joint names"});
}

TEST(SurfaceTexture, PhotographicDetailAddsGrainAGradientAndPrint) {
  // Points anywhere in the body's box, skinned to one bone whose plain albedo
  // is light (a checker, no face, hands or shoes): the photographic albedo
  // over the plain one is the grain times the gradient, except where print
  // darkens it.
  const auto& tiny = testing::tiny_image_dataset();
  const ImageDataset data(tiny.dir);
  const auto& c = data.character();
  const auto vertices = c.mesh.vertices.to(torch::kFloat32);
  std::vector<std::string> names;
  for (int64_t j = 0; j < c.num_joints(); ++j) names.push_back("bone." + std::to_string(j));  // no SMPL parts
  const SurfaceTexture plain(vertices, c.weights, names), photographic(vertices, c.weights, names, true);
  std::vector<float> w(static_cast<size_t>(c.num_joints()), 0.0f);
  w[1] = 1;  // bone 1: the checker
  const auto lo = std::get<0>(vertices.min(0)), hi = std::get<0>(vertices.max(0));
  const int long_axis = static_cast<int>((hi - lo).argmax().item<int64_t>());
  torch::manual_seed(0);
  const auto points = (lo + torch::rand({4000, 3}) * (hi - lo)).contiguous();
  const auto p = points.accessor<float, 2>();
  std::vector<double> low, high, band;  // green's ratio below a quarter, above three quarters, in [0.4, 0.5)
  int64_t printed = 0;
  for (int64_t i = 0; i < points.size(0); ++i) {
    const Eigen::Vector3f q(p[i][0], p[i][1], p[i][2]);
    const Eigen::Vector3f a = plain.albedo(q, w.data()), b = photographic.albedo(q, w.data());
    ASSERT_GE(a.minCoeff(), 0.3f);
    EXPECT_TRUE(b == photographic.albedo(q, w.data()));  // the same at the same point
    if (b.maxCoeff() < 0.2f) {
      ++printed;
      continue;
    }
    const double along = (p[i][long_axis] - lo[long_axis].item<float>()) / (hi - lo)[long_axis].item<float>();
    const double ratio = b.y() / a.y();  // green: no tint
    if (along < 0.25) low.push_back(ratio);
    if (along > 0.75) high.push_back(ratio);
    if (along >= 0.4 && along < 0.5) band.push_back(ratio);
  }
  const double fraction = static_cast<double>(printed) / static_cast<double>(points.size(0));
  EXPECT_GT(fraction, 0.02);
  EXPECT_LT(fraction, 0.2);
  const auto mean = [](const std::vector<double>& v) {
    double sum = 0;
    for (const double x : v) sum += x;
    return sum / static_cast<double>(v.size());
  };
  EXPECT_GT(mean(high) - mean(low), 0.15);  // the gradient: 0.8 to 1.15 x
  // The grain: in a band a tenth of the height across (the gradient there
  // varies by 0.01 sd) the ratio still varies from point to point.
  double spread = 0;
  const double m = mean(band);
  for (const double x : band) spread += (x - m) * (x - m);
  EXPECT_GT(std::sqrt(spread / static_cast<double>(band.size())), 0.02);
  // Through a dataset: recorded in the manifest; other names refused.
  const auto dir = testing::temp_dir("image_dataset_photographic");
  auto options = testing::tiny_image_options(dir.string());
  options.texture = "photographic";
  build_image_dataset(tiny.model, tiny.poses, tiny.held_out, options);
  const auto manifest = nlohmann::json::parse(read_file((dir / "manifest.json").string()));
  EXPECT_EQ(manifest.at("texture_detail"), "photographic");
  EXPECT_FALSE(torch::equal(ImageDataset(dir.string()).load_split("train").images,
                            ImageDataset(tiny.dir).load_split("train").images));
  options.texture = "photo";
  testing::expect_error([&] { build_image_dataset(tiny.model, tiny.poses, tiny.held_out, options); },
                        {"plain or photographic", "photo"});
}

}  // namespace
}  // namespace fskin
