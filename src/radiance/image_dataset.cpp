#include "fskin/radiance/image_dataset.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/core/plausibility.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/dataset_builder.h"
#include "fskin/data/dataset_posing.h"
#include "fskin/export/image.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/avatar_character.h"
#include "fskin/util/atomic_file.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

nlohmann::json read_json(const std::string& path) {
  FSKIN_CHECK(fs::exists(path), "{}: missing (not an image dataset? build one with `fskin data images`)", path);
  try {
    return nlohmann::json::parse(read_file(path));
  } catch (const nlohmann::json::exception& e) {
    fail("{}: not valid JSON ({})", path, e.what());
  }
}


// Each camera must have the subject in front of it and near its image: the
// subject's centre (the canonical vertices' mean carried by the bones, each
// by its share of the weights) projected with the image's camera.
void check_cameras_see_the_subject(const ImageSplit& split, const RiggedMesh& character,
                                   const std::string& camera_path) {
  if (split.size() == 0) return;
  const auto centre = character.mesh.vertices.to(torch::kFloat64).mean(0);          // [3]
  const auto share = character.weights.to(torch::kFloat64).mean(0);            // [J]
  const auto bones = split.bone_transforms.to(torch::kFloat64);               // [N, J, 4, 4]
  const auto moved = torch::matmul(bones.narrow(2, 0, 3).narrow(3, 0, 3), centre) +
                     bones.narrow(2, 0, 3).select(3, 3);                       // [N, J, 3]
  const auto posed = (moved * share.view({1, -1, 1})).sum(1) / share.sum();   // [N, 3]
  const auto a = posed.accessor<double, 2>();
  for (int64_t i = 0; i < split.size(); ++i) {
    const auto& camera = split.cameras[i];
    const Eigen::Vector3d world(a[i][0], a[i][1], a[i][2]);
    const Eigen::Vector3d in_camera =
        camera.extrinsic.topLeftCorner<3, 3>() * world + camera.extrinsic.topRightCorner<3, 1>();
    FSKIN_CHECK(in_camera.z() > 0, "{}: camera {} has the subject behind it (its centre at depth {:.3g})", camera_path,
                i, in_camera.z());
    const Eigen::Vector2d pixel = camera.project(world);
    FSKIN_CHECK(pixel.x() > -camera.width && pixel.x() < 2.0 * camera.width && pixel.y() > -camera.height &&
                    pixel.y() < 2.0 * camera.height,
                "{}: camera {} does not see the subject (its centre projects to pixel ({:.4g}, {:.4g}), far outside the "
                "{}x{} image)",
                camera_path, i, pixel.x(), pixel.y(), camera.width, camera.height);
  }
}

// A split whose masks are all empty has no subject to learn; some empty
// masks (the subject out of frame) are reported.
void check_masks_hold_a_subject(const ImageSplit& split, const std::string& mask_dir) {
  if (split.size() == 0) return;
  const auto subject_pixels = (split.masks > 127).flatten(1).sum(1);
  const int64_t empty = (subject_pixels == 0).sum().item<int64_t>();
  FSKIN_CHECK(empty < split.size(), "{}: all {} masks are empty (no pixel above 127): there is no subject to learn",
              mask_dir, split.size());
  if (empty > 0)
    std::fprintf(stderr, "fskin: warning: %s: %lld of %lld masks are empty (no subject in view)\n", mask_dir.c_str(),
                 static_cast<long long>(empty), static_cast<long long>(split.size()));
}

}  // namespace

std::string image_file_name(int64_t index) { return fmt::format("image_{:04d}.png", index); }
std::string mask_file_name(int64_t index) { return fmt::format("mask_{:04d}.png", index); }

std::vector<PinholeCamera> load_cameras(const std::string& camera_path, int64_t n) {
  FSKIN_CHECK(fs::exists(camera_path), "{}: missing", camera_path);
  std::vector<PinholeCamera> cameras;
  const io::NpzReader camera_file(camera_path);
  auto intrinsic = camera_file.tensor("intrinsic");
  auto extrinsic = camera_file.tensor("extrinsic");
  expect_floating(intrinsic, camera_path + ": intrinsic");
  expect_floating(extrinsic, camera_path + ": extrinsic");
  intrinsic = intrinsic.to(torch::kFloat64);
  extrinsic = extrinsic.to(torch::kFloat64);
  const auto height = camera_file.tensor("height").reshape({-1}).to(torch::kFloat64);
  const auto width = camera_file.tensor("width").reshape({-1}).to(torch::kFloat64);
  FSKIN_CHECK(height.numel() == 1 && width.numel() == 1, "{}: height and width must be single numbers", camera_path);
  const double h = height.item<double>(), w = width.item<double>();
  FSKIN_CHECK(h >= 1 && w >= 1 && h <= kMaxImageSide && w <= kMaxImageSide && h == std::floor(h) && w == std::floor(w),
              "{}: height and width must be whole numbers within 1..{}, got {:g} x {:g}", camera_path, kMaxImageSide,
              w, h);
  const std::string layout = "one camera, or one per image of poses.npz";
  FSKIN_CHECK((intrinsic.dim() == 2 || intrinsic.dim() == 3) && intrinsic.size(-2) == 3 && intrinsic.size(-1) == 3,
              "{}: intrinsic must be (3, 3) or (N, 3, 3) ({}), got {}", camera_path, layout,
              shape_string(intrinsic.sizes()));
  FSKIN_CHECK((extrinsic.dim() == 2 || extrinsic.dim() == 3) && (extrinsic.size(-2) == 3 || extrinsic.size(-2) == 4) &&
                  extrinsic.size(-1) == 4,
              "{}: extrinsic must be (4, 4), (3, 4), (N, 4, 4) or (N, 3, 4) ({}), got {}", camera_path, layout,
              shape_string(extrinsic.sizes()));
  if (n < 0) n = extrinsic.dim() == 3 ? extrinsic.size(0) : intrinsic.dim() == 3 ? intrinsic.size(0) : 1;
  if (intrinsic.dim() == 2) intrinsic = intrinsic.unsqueeze(0).expand({n, 3, 3});
  if (extrinsic.dim() == 2) extrinsic = extrinsic.unsqueeze(0).expand({n, -1, -1});
  if (extrinsic.size(1) == 3)  // [R | t] without the last row
    extrinsic = torch::cat({extrinsic, torch::tensor({0.0, 0.0, 0.0, 1.0}, torch::kFloat64).expand({extrinsic.size(0), 1, 4})}, 1);
  expect_shape(intrinsic, {n, 3, 3}, camera_path + ": intrinsic (" + layout + ")");
  expect_shape(extrinsic, {n, 4, 4}, camera_path + ": extrinsic (" + layout + ")");
  expect_plausible(extrinsic, camera_path + ": extrinsic");
  intrinsic = intrinsic.contiguous();
  extrinsic = extrinsic.contiguous();
  for (int64_t i = 0; i < n; ++i) {
    cameras.push_back(PinholeCamera::from_matrices(intrinsic[i], extrinsic[i], static_cast<int>(w),
                                                   static_cast<int>(h), fmt::format("{}: camera {}", camera_path, i)));
  }
  return cameras;
}

ImageDataset::ImageDataset(std::string dir) : dir_(std::move(dir)) {
  const auto manifest_path = (fs::path(dir_) / "manifest.json").string();
  const auto manifest = read_json(manifest_path);
  // The fields a dataset made elsewhere must have (docs/image_datasets.md).
  for (const auto& [field, example] : {std::pair<const char*, const char*>{"format", "\"fskin-image-dataset\""},
                                       {"background", "[1, 1, 1] (linear RGB in [0, 1])"},
                                       {"splits", "[\"train\", \"novel_view\", \"novel_pose\"]"}})
    FSKIN_CHECK(manifest.is_object() && manifest.contains(field), "{}: no \"{}\" field; an image dataset's manifest needs "
                "format, background and splits, e.g. \"{}\": {}",
                manifest_path, field, field, example);
  try {
    FSKIN_CHECK(manifest.at("format").get<std::string>() == "fskin-image-dataset",
                "{}: format is '{}', not an fskin image dataset", manifest_path, manifest.at("format").dump());
    FSKIN_CHECK(manifest.value("complete", true),
                "{}: the dataset is incomplete (its build was interrupted); run `fskin data images` again with "
                "the same arguments to finish it",
                manifest_path);
    const auto bg = manifest.at("background").get<std::vector<double>>();
    FSKIN_CHECK(bg.size() == 3, "{}: background must have 3 components", manifest_path);
    for (const double c : bg)
      FSKIN_CHECK(c >= 0 && c <= 1, "{}: background components must be within [0, 1] (linear RGB), got {}",
                  manifest_path, c);
    std::copy(bg.begin(), bg.end(), background_.begin());
    splits_ = manifest.at("splits").get<std::vector<std::string>>();
    for (const auto& split : splits_) {
      // A split is a directory of this dataset: a plain name, not a path.
      const bool plain = !split.empty() && split != "." && split != ".." && split.find_first_of("/\\") == std::string::npos;
      FSKIN_CHECK(plain, "{}: split '{}' is not a directory name inside the dataset", manifest_path, split);
    }
    model_source_ = manifest.value("model", std::string());
    canonical_pose_option_ = manifest.value("canonical_pose_option", std::string("default"));
  } catch (const nlohmann::json::exception& e) {
    fail("{}: {}", manifest_path, e.what());
  }
  character_ = load_canonical_character((fs::path(dir_) / "canonical.npz").string());
}

ImageSplit ImageDataset::load_split(const std::string& split) const {
  FSKIN_CHECK(std::find(splits_.begin(), splits_.end(), split) != splits_.end(),
              "{}: no split '{}' (it has: {})", dir_, split, fmt::format("{}", fmt::join(splits_, ", ")));
  const fs::path split_dir = fs::path(dir_) / split;
  ImageSplit out;
  out.name = split;
  const std::string pose_path = (split_dir / "poses.npz").string();
  FSKIN_CHECK(fs::exists(pose_path), "{}: missing", pose_path);
  const io::NpzReader pose_file(pose_path);
  out.bone_transforms = load_bone_transforms(pose_path, character_.num_joints());
  const int64_t n = out.bone_transforms.size(0);
  out.pose_index = pose_file.contains("pose_index") ? pose_file.tensor("pose_index").to(torch::kInt64)
                                                    : torch::arange(n, torch::kInt64);
  out.view_index = pose_file.contains("view_index") ? pose_file.tensor("view_index").to(torch::kInt64)
                                                    : torch::zeros({n}, torch::kInt64);
  expect_shape(out.pose_index, {n}, pose_path + ": pose_index");
  expect_shape(out.view_index, {n}, pose_path + ": view_index");

  const std::string camera_path = (split_dir / "cameras.npz").string();
  out.cameras = load_cameras(camera_path, n);
  const int W = n > 0 ? out.cameras[0].width : 0, H = n > 0 ? out.cameras[0].height : 0;
  out.images = torch::empty({n, H, W, 3}, torch::kUInt8);
  out.masks = torch::empty({n, H, W}, torch::kUInt8);
  for (int64_t i = 0; i < n; ++i) {
    const auto image_path = (split_dir / "images" / image_file_name(i)).string();
    const auto mask_path = (split_dir / "masks" / mask_file_name(i)).string();
    FSKIN_CHECK(fs::exists(image_path), "{}: missing ({} has {} frames)", image_path, pose_path, n);
    FSKIN_CHECK(fs::exists(mask_path), "{}: missing ({} has {} frames)", mask_path, pose_path, n);
    const Image image = read_png(image_path);
    FSKIN_CHECK(image.width == W && image.height == H, "{}: {}x{} pixels, but {} says {}x{}", image_path, image.width,
                image.height, camera_path, W, H);
    std::memcpy(out.images[i].data_ptr<uint8_t>(), image.rgb.data(), image.rgb.size());
    int mw = 0, mh = 0;
    const auto mask = read_png_gray(mask_path, mw, mh);
    FSKIN_CHECK(mw == W && mh == H, "{}: {}x{} pixels, but {} says {}x{}", mask_path, mw, mh, camera_path, W, H);
    std::memcpy(out.masks[i].data_ptr<uint8_t>(), mask.data(), mask.size());
  }
  check_cameras_see_the_subject(out, character_, camera_path);
  check_masks_hold_a_subject(out, (split_dir / "masks").string());
  return out;
}

torch::Tensor ImageDataset::bone_transforms(const PoseSet& poses, const std::string& context,
                                           const std::string& model_path) const {
  torch::NoGradGuard no_grad;
  const std::string path = model_path.empty() ? model_source_ : model_path;
  FSKIN_CHECK(!path.empty(), "{}: the manifest records no body model; pass one to pose new poses", dir_);
  FSKIN_CHECK(fs::exists(path), "{}: body model {} (recorded in its manifest) is missing; pass the model file", dir_,
              path);
  auto model = BodyModel::load(path);
  const auto pose = canonical_pose(model, canonical_pose_option_);
  const auto canonical = model.pose(pose.unsqueeze(0));
  FSKIN_CHECK(canonical.vertices[0].sizes() == character_.mesh.vertices.sizes() &&
                  torch::allclose(canonical.vertices[0], character_.mesh.vertices, 1e-4, 1e-5),
              "{}: {} is not the body model this dataset was built from (its canonical vertices differ)", dir_, path);
  return DatasetPosing::from_model(std::move(model), pose).bone_transforms(poses, context);
}

torch::Tensor load_bone_transforms(const std::string& path, int64_t joints) {
  FSKIN_CHECK(fs::exists(path), "{}: missing", path);
  const io::NpzReader file(path);
  FSKIN_CHECK(file.contains("bone_transforms"), "{}: no bone_transforms array (canonical -> posed, [N, J, 4, 4])",
              path);
  auto bones = file.tensor("bone_transforms");
  expect_floating(bones, path + ": bone_transforms");
  bones = bones.to(torch::kFloat32).contiguous();
  expect_shape(bones, {-1, joints, 4, 4},
               path + ": bone_transforms (for the " + std::to_string(joints) + " joints of canonical.npz)");
  expect_plausible(bones, path + ": bone_transforms");
  return bones;
}

bool image_dataset_mesh_is_fitted(const std::string& dir) {
  const auto path = fs::path(dir) / "manifest.json";
  std::error_code ignored;
  if (dir.empty() || !fs::is_regular_file(path, ignored)) return false;
  try {
    const auto manifest = nlohmann::json::parse(read_file(path.string()));
    return manifest.is_object() && manifest.contains("capture");
  } catch (const std::exception&) {
    return false;  // the training reads the manifest itself and names what is wrong
  }
}

std::array<int64_t, 4> mask_box(const torch::Tensor& mask, double grow) {
  FSKIN_CHECK(mask.dim() == 2, "mask_box: mask must be [H, W]");
  const int64_t H = mask.size(0), W = mask.size(1);
  const auto on = mask > 0;
  const auto rows = torch::nonzero(on.any(1)).reshape({-1}), cols = torch::nonzero(on.any(0)).reshape({-1});
  if (rows.numel() == 0) return {0, 0, W, H};
  const int64_t v0 = rows.min().item<int64_t>(), v1 = rows.max().item<int64_t>() + 1;
  const int64_t u0 = cols.min().item<int64_t>(), u1 = cols.max().item<int64_t>() + 1;
  const auto gu = static_cast<int64_t>(std::ceil(0.5 * grow * static_cast<double>(u1 - u0)));
  const auto gv = static_cast<int64_t>(std::ceil(0.5 * grow * static_cast<double>(v1 - v0)));
  return {std::max<int64_t>(0, u0 - gu), std::max<int64_t>(0, v0 - gv), std::min(W, u1 + gu), std::min(H, v1 + gv)};
}

}  // namespace fskin
