// A capture in InstantAvatar's PeopleSnapshot layout, made from fskin's own
// tiny image dataset (so the truth is known), converted back into an image
// dataset: the same bone transforms, cameras and pixels.
#include "fskin/radiance/capture_import.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>

#include "fskin/data/dataset_builder.h"
#include "fskin/export/image.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/image_dataset.h"
#include "radiance/tiny_image_dataset.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

// The tiny dataset's train split as a PeopleSnapshot capture: images, float
// .npy masks, per-image cameras and SMPL-style parameters (thetas [N, 3J]).
fs::path make_capture(const std::string& name, const torch::Tensor& betas) {
  const auto& tiny = testing::tiny_image_dataset();
  const fs::path capture = testing::temp_dir(name), split = fs::path(tiny.dir) / "train";
  fs::create_directories(capture / "images");
  fs::create_directories(capture / "masks");
  const io::NpzReader poses((split / "poses.npz").string());
  const auto pose_index = poses.tensor("pose_index");
  const int64_t N = pose_index.size(0);
  for (int64_t i = 0; i < N; ++i) {
    fs::copy_file(split / "images" / image_file_name(i), capture / "images" / image_file_name(i));
    int w = 0, h = 0;
    const auto mask = read_png_gray((split / "masks" / mask_file_name(i)).string(), w, h);
    io::write_npy((capture / "masks" / fmt::format("mask_{:04d}.npy", i)).string(),
                  torch::tensor(std::vector<float>(mask.begin(), mask.end())).reshape({h, w}) / 255.0);
  }
  fs::copy_file(split / "cameras.npz", capture / "cameras.npz");
  io::NpzWriter smpl;
  smpl.add("thetas", tiny.poses.poses.index_select(0, pose_index).reshape({N, -1}).contiguous());
  smpl.add("transl", tiny.poses.trans.index_select(0, pose_index).contiguous());
  smpl.add("betas", betas);
  smpl.save((capture / "poses.npz").string());
  tiny.model.save((capture / "model.npz").string());
  return capture;
}

CaptureImportOptions options_for(const fs::path& capture, const std::string& out) {
  CaptureImportOptions options;
  options.capture_dir = capture.string();
  options.model_path = (capture / "model.npz").string();
  options.out_dir = testing::temp_dir(out).string();
  options.novel_pose = "4:6";
  options.progress = false;
  return options;
}

TEST(CaptureImport, APeopleSnapshotCaptureBecomesTheDatasetItWasMadeFrom) {
  const auto& tiny = testing::tiny_image_dataset();
  const auto capture = make_capture("capture_exact", torch::zeros({10}));  // more betas than the model's, all zero
  const auto options = options_for(capture, "capture_exact_out");
  const auto summary = import_capture(options);
  EXPECT_EQ(summary.train, 6);
  EXPECT_EQ(summary.novel_pose, 2);
  const ImageDataset original(tiny.dir), imported(options.out_dir);
  EXPECT_EQ(imported.split_names(), (std::vector<std::string>{"train", "novel_pose"}));
  EXPECT_TRUE(torch::allclose(imported.character().mesh.vertices, original.character().mesh.vertices, 1e-5, 1e-6));
  const auto want = original.load_split("train"), got = imported.load_split("train");
  ASSERT_EQ(got.size(), want.size());
  EXPECT_TRUE(torch::allclose(got.bone_transforms, want.bone_transforms, 1e-5, 1e-5));
  for (int64_t i = 0; i < got.size(); ++i) {
    EXPECT_TRUE(got.cameras[i].intrinsic.isApprox(want.cameras[i].intrinsic)) << i;
    // Where the mask is all subject or all background the pixel is the original's
    // (its background is white, as the import's).
    const auto whole = (want.masks[i] == 255) | (want.masks[i] == 0);
    EXPECT_TRUE(torch::equal(got.images[i].index({whole}), want.images[i].index({whole}))) << i;
    EXPECT_TRUE(torch::equal(got.masks[i], want.masks[i])) << i;
  }
  const auto held_out = imported.load_split("novel_pose");
  ASSERT_EQ(held_out.size(), 2);
  EXPECT_TRUE(torch::allclose(held_out.bone_transforms, want.bone_transforms.narrow(0, 4, 2), 1e-5, 1e-5));
  // Its mesh is a body model fitted to the photographs; the original's is the subject's own.
  EXPECT_TRUE(image_dataset_mesh_is_fitted(options.out_dir));
  EXPECT_FALSE(image_dataset_mesh_is_fitted(tiny.dir));
  EXPECT_FALSE(image_dataset_mesh_is_fitted(testing::temp_dir("no_dataset_here").string()));
  // Run again: everything is there, nothing is written.
  EXPECT_EQ(import_capture(options).images_skipped, 8);

  // Pose files aligned with a split's frames, as InstantAvatar keeps its
  // refined fits: the novel_pose split from frames 4 and 5's own rows.
  const io::NpzReader all((capture / "poses.npz").string());
  io::NpzWriter aligned;
  aligned.add("global_orient", all.tensor("thetas").narrow(0, 4, 2).narrow(1, 0, 3).contiguous());
  aligned.add("body_pose", all.tensor("thetas").narrow(0, 4, 2).narrow(1, 3, 69).contiguous());
  aligned.add("transl", all.tensor("transl").narrow(0, 4, 2).contiguous());
  aligned.save((capture / "anim_nerf_test.npz").string());
  auto split_files = options_for(capture, "capture_aligned_out");
  split_files.train = "0:4";
  split_files.novel_pose_poses = (capture / "anim_nerf_test.npz").string();
  import_capture(split_files);
  EXPECT_TRUE(torch::allclose(ImageDataset(split_files.out_dir).load_split("novel_pose").bone_transforms,
                              held_out.bone_transforms, 1e-5, 1e-5));
  split_files.out_dir = testing::temp_dir("capture_aligned_bad").string();
  split_files.novel_pose = "3:6";
  testing::expect_error([&] { import_capture(split_files); }, {"anim_nerf_test.npz", "2 poses", "3 frames"});
}

TEST(CaptureImport, BetasShapeTheCanonicalBody) {
  const auto& tiny = testing::tiny_image_dataset();
  const auto betas = torch::tensor({1.5f, -1.0f});
  const auto capture = make_capture("capture_betas", betas.reshape({1, 2}));
  auto options = options_for(capture, "capture_betas_out");
  options.train = "0:6:2";
  options.novel_pose.clear();
  import_capture(options);
  const ImageDataset imported(options.out_dir);
  const auto canonical = tiny.model.pose(canonical_pose(tiny.model, "default").unsqueeze(0), betas.reshape({1, 2}));
  EXPECT_TRUE(torch::allclose(imported.character().mesh.vertices, canonical.vertices[0], 1e-5, 1e-6));
  EXPECT_FALSE(torch::allclose(imported.character().mesh.vertices, ImageDataset(tiny.dir).character().mesh.vertices,
                               1e-3, 1e-3));
  EXPECT_EQ(imported.load_split("train").size(), 3);  // frames 0, 2, 4
}

TEST(CaptureImport, BadCapturesAreNamed) {
  const auto capture = make_capture("capture_bad", torch::zeros({2}));
  auto options = options_for(capture, "capture_bad_out");
  options.train = "5:3";
  testing::expect_error([&] { import_capture(options); }, {"--train", "5:3"});
  options.train = "0:";
  options.novel_pose = "4:60";
  testing::expect_error([&] { import_capture(options); }, {"--novel-pose", "6 frames"});
  options.novel_pose.clear();
  io::write_npy((capture / "masks" / "mask_0003.npy").string(), torch::zeros({5, 5}));
  testing::expect_error([&] { import_capture(options); }, {"mask_0003.npy", "40 x 40"});
  io::NpzWriter no_pose;
  no_pose.add("transl", torch::zeros({6, 3}));
  no_pose.save((capture / "poses.npz").string());
  testing::expect_error([&] { import_capture(options); }, {"poses.npz", "thetas", "global_orient"});
  io::NpzWriter too_many_betas;
  too_many_betas.add("thetas", torch::zeros({6, 72}));
  too_many_betas.add("betas", torch::ones({10}));
  too_many_betas.save((capture / "poses.npz").string());
  testing::expect_error([&] { import_capture(options); }, {"10 betas", "2 shape blend shapes"});
  io::NpzWriter smplx;
  smplx.add("thetas", torch::zeros({6, 165}));
  smplx.save((capture / "poses.npz").string());
  testing::expect_error([&] { import_capture(options); }, {"165 values per frame", "24 joints"});
}

}  // namespace
}  // namespace fskin
