#include "fskin/export/gltf_animation.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cstdlib>
#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

// A tetrahedron that moves and deforms over `num_frames` frames.
MeshAnimation moving_tetrahedron(int64_t num_frames) {
  MeshAnimation animation;
  animation.faces =
      torch::tensor({0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}, torch::kInt64).reshape({4, 3});
  const auto rest = torch::tensor({0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f,
                                   0.0f, 1.0f})
                        .reshape({1, 4, 3});
  torch::manual_seed(7);
  animation.frames = rest + 0.3f * torch::rand({num_frames, 4, 3});
  animation.colors = torch::tensor({255, 0, 0, 0, 255, 0, 0, 0, 255, 9, 99, 199}, torch::kUInt8)
                         .reshape({4, 3});
  animation.fps = 24;
  return animation;
}

void expect_round_trip(const std::string& path, const MeshAnimation& written) {
  write_gltf_animation(path, written);
  const MeshAnimation read = read_gltf_animation(path);
  EXPECT_EQ(read.num_frames(), written.num_frames());
  ASSERT_EQ(read.frames.sizes(), written.frames.sizes());
  EXPECT_TRUE(torch::allclose(read.frames, written.frames, /*rtol=*/0, /*atol=*/1e-6));
  EXPECT_TRUE(torch::equal(read.frames[0], written.frames[0])) << "frame 0 is stored as is";
  EXPECT_TRUE(torch::equal(read.faces, written.faces));
  ASSERT_EQ(read.colors.defined(), written.colors.defined());
  if (written.colors.defined()) EXPECT_TRUE(torch::equal(read.colors, written.colors));
  if (written.num_frames() > 1) EXPECT_NEAR(read.fps, written.fps, 1e-4);
}

TEST(GltfAnimation, BinaryRoundTrip) {
  const auto dir = testing::temp_dir("gltf_glb");
  const auto path = (dir / "anim.glb").string();
  expect_round_trip(path, moving_tetrahedron(6));
  EXPECT_EQ(read_file(path).substr(0, 4), "glTF");  // GLB magic
  for (const auto& entry : fs::directory_iterator(dir))  // no temporary files left
    EXPECT_EQ(entry.path().filename().string(), "anim.glb");
  fs::remove_all(dir);
}

TEST(GltfAnimation, EmbeddedJsonRoundTripWithoutColours) {
  const auto dir = testing::temp_dir("gltf_json");
  auto animation = moving_tetrahedron(3);
  animation.colors = torch::Tensor();
  const auto path = (dir / "anim.gltf").string();
  expect_round_trip(path, animation);
  const std::string text = read_file(path);
  EXPECT_NE(text.find("data:application/octet-stream;base64,"), std::string::npos);
  EXPECT_NE(text.find("\"STEP\""), std::string::npos);
  EXPECT_NE(text.find("frame_0002"), std::string::npos);
  fs::remove_all(dir);
}

TEST(GltfAnimation, SingleFrameIsAStaticMesh) {
  const auto dir = testing::temp_dir("gltf_static");
  const auto path = (dir / "still.glb").string();
  expect_round_trip(path, moving_tetrahedron(1));
  fs::remove_all(dir);
}

TEST(GltfAnimation, KhronosValidatorAndThreeJsAcceptIt) {
  // What Blender and three.js users open: checked by the reference validator
  // and by three.js's loader (tools/gltf-check), both file flavours.
  const auto dir = testing::temp_dir("gltf_viewers");
  const auto glb = (dir / "anim.glb").string(), gltf = (dir / "anim.gltf").string(),
             log = (dir / "check.txt").string();
  write_gltf_animation(glb, moving_tetrahedron(5));
  auto without_colours = moving_tetrahedron(2);
  without_colours.colors = torch::Tensor();
  write_gltf_animation(gltf, without_colours);
  const std::string command =
      "node " + std::string(FSKIN_GLTF_CHECK) + " " + glb + " " + gltf + " > " + log + " 2>&1";
  const int status = std::system(command.c_str());
  const std::string output = read_file(log);
  ASSERT_EQ(status, 0) << output << "\n(scripts/setup.sh installs node and the checkers)";
  EXPECT_NE(output.find("\"errors\":0,\"warnings\":0"), std::string::npos) << output;
  EXPECT_NE(output.find("\"vertices\":4,\"triangles\":4,\"frames\":5"), std::string::npos) << output;
  EXPECT_NE(output.find("\"frames\":2"), std::string::npos) << output;
  fs::remove_all(dir);
}

TEST(GltfAnimation, BadInputThrows) {
  const auto dir = testing::temp_dir("gltf_bad");
  const auto path = (dir / "bad.glb").string();
  const auto good = moving_tetrahedron(3);
  auto bad = good;
  bad.frames = torch::zeros({0, 4, 3});
  EXPECT_THROW(write_gltf_animation(path, bad), Error);
  bad = good;
  bad.frames = torch::zeros({3, 4, 2});
  EXPECT_THROW(write_gltf_animation(path, bad), Error);
  bad = good;
  bad.frames = good.frames.slice(1, 0, 3);  // faces refer to vertex 3
  EXPECT_THROW(write_gltf_animation(path, bad), Error);
  bad = good;
  bad.colors = good.colors.slice(0, 0, 3);
  EXPECT_THROW(write_gltf_animation(path, bad), Error);
  bad = good;
  bad.frames = good.frames.clone();
  bad.frames[2][1][0] = std::nanf("");
  testing::expect_error([&] { write_gltf_animation(path, bad); }, {"bad.glb", "frame 2"});
  bad = good;
  bad.fps = 0;
  EXPECT_THROW(write_gltf_animation(path, bad), Error);
  testing::expect_error([&] { write_gltf_animation((dir / "anim.obj").string(), good); },
                        {"anim.obj", ".glb"});
  EXPECT_FALSE(fs::exists(path));
  write_file_atomically(path, "not a glTF file");
  testing::expect_error([&] { read_gltf_animation(path); }, {"bad.glb", "not a readable glTF"});
  EXPECT_THROW(read_gltf_animation((dir / "missing.glb").string()), Error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fskin
