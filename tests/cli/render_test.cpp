// The `fskin render` and `fskin animate` commands, run as a user would.
#include <gtest/gtest.h>
#include <stb/stb_image.h>
#include <torch/torch.h>

#include <cstdlib>
#include <filesystem>

#include "fskin/body/body_model.h"
#include "fskin/export/gltf_animation.h"
#include "fskin/io/mesh_io.h"
#include "test_util.h"

namespace fskin {
namespace {

int run_cli(const std::string& arguments) {
  return std::system((std::string(FSKIN_CLI_PATH) + " " + arguments + " > /dev/null 2>&1").c_str());
}

// A tetrahedron rigged to two bones.
BodyModel tetrahedron_model() {
  BodyModelData d;
  d.v_template =
      torch::tensor({0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f})
          .reshape({4, 3});
  d.faces = torch::tensor({0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}, torch::kInt64).reshape({4, 3});
  d.weights = torch::tensor({1.0f, 0.0f, 0.0f, 1.0f, 0.5f, 0.5f, 1.0f, 0.0f}).reshape({4, 2});
  d.J_regressor = torch::tensor({1.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f}).reshape({2, 4});
  d.parents = {-1, 0};
  d.joint_names = {"root", "tip"};
  return BodyModel(std::move(d), "tetrahedron");
}

std::pair<int, int> png_size(const std::string& path) {
  int width = 0, height = 0, channels = 0;
  EXPECT_EQ(stbi_info(path.c_str(), &width, &height, &channels), 1) << path;
  return {width, height};
}

TEST(RenderCommand, WritesGridsOfMeshesAndModels) {
  const auto dir = testing::temp_dir("cli_render");
  const auto model = tetrahedron_model();
  model.save((dir / "model.npz").string());
  const Mesh mesh = model.template_mesh();
  io::write_mesh((dir / "a.ply").string(), mesh);
  Mesh moved = mesh;
  moved.vertices = mesh.vertices + 0.5;
  io::write_mesh((dir / "b.ply").string(), moved);

  const auto picture = (dir / "grid.png").string();
  ASSERT_EQ(run_cli("render --mesh " + (dir / "a.ply").string() + " --mesh " +
                    (dir / "b.ply").string() + " --view all --width 32 --height 40 --out " +
                    picture),
            0);
  EXPECT_EQ(png_size(picture), std::make_pair(4 * 32, 2 * 40));
  ASSERT_EQ(run_cli("render --model " + (dir / "model.npz").string() +
                    " --color-by-bone --turntable 3 --width 20 --height 20 --out " + picture),
            0);
  EXPECT_EQ(png_size(picture), std::make_pair(3 * 20, 20));

  EXPECT_NE(run_cli("render --out " + picture), 0) << "nothing to render";
  EXPECT_NE(run_cli("render --mesh " + (dir / "a.ply").string() + " --color-by-bone --out " +
                    picture),
            0)
      << "--color-by-bone needs --model";
  EXPECT_NE(run_cli("render --mesh " + (dir / "missing.ply").string() + " --out " + picture), 0);
  std::filesystem::remove_all(dir);
}

TEST(AnimateCommand, WritesMeshFramesAsGltf) {
  const auto dir = testing::temp_dir("cli_animate");
  const auto model = tetrahedron_model();
  model.save((dir / "model.npz").string());
  std::string meshes;
  for (int t = 0; t < 3; ++t) {
    Mesh frame = model.template_mesh();
    frame.vertices = frame.vertices * (1.0f + 0.1f * t);
    const auto path = (dir / ("frame_" + std::to_string(t) + ".ply")).string();
    io::write_mesh(path, frame);
    meshes += " --mesh " + path;
  }
  const auto out = (dir / "anim.glb").string();
  ASSERT_EQ(run_cli("animate" + meshes + " --model " + (dir / "model.npz").string() +
                    " --color-by-bone --fps 12 --out " + out),
            0);
  const auto animation = read_gltf_animation(out);
  EXPECT_EQ(animation.num_frames(), 3);
  EXPECT_NEAR(animation.fps, 12, 1e-3);
  EXPECT_TRUE(animation.colors.defined());
  EXPECT_TRUE(torch::allclose(animation.frames[2], model.data().v_template * 1.2f, 0, 1e-6));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace fskin
