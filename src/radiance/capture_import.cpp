#include "fskin/radiance/capture_import.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "fskin/body/body_model.h"
#include "fskin/core/error.h"
#include "fskin/core/plausibility.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/build_manifest.h"
#include "fskin/data/dataset_builder.h"
#include "fskin/export/image.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/avatar_character.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/skeleton/forward_kinematics.h"
#include "fskin/util/atomic_file.h"
#include "fskin/util/progress.h"
#include "fskin/version.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

int64_t parse_int(const std::string& text, const std::string& what) {
  size_t used = 0;
  int64_t value = 0;
  try {
    value = std::stoll(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  FSKIN_CHECK(used == text.size() && !text.empty(), "{}: '{}' is not an integer", what, text);
  return value;
}

// The capture's SMPL-family parameters, one row per frame.
struct CapturePoses {
  torch::Tensor axis_angle;  // [N, J, 3]
  torch::Tensor transl;      // [N, 3]
  torch::Tensor betas;       // [1, S] or undefined
};

CapturePoses read_capture_poses(const std::string& path, const BodyModel& model) {
  FSKIN_CHECK(fs::exists(path), "{}: missing (the capture's SMPL parameters: thetas or global_orient + body_pose, "
              "transl, betas)", path);
  const io::NpzReader file(path);
  const int64_t J = model.num_joints();
  const auto floating = [&](const std::string& key) {
    auto t = file.tensor(key);
    expect_floating(t, path + ": " + key);
    t = t.to(torch::kFloat32).contiguous();
    expect_plausible(t, path + ": " + key);
    return t;
  };
  torch::Tensor pose;
  if (file.contains("thetas")) {
    pose = floating("thetas");
  } else {
    FSKIN_CHECK(file.contains("global_orient") && file.contains("body_pose"),
                "{}: no pose: needs thetas (N, {}) or global_orient (N, 3) and body_pose (N, {}) (it has: {})", path,
                3 * J, 3 * J - 3, fmt::format("{}", fmt::join(file.keys(), ", ")));
    const auto root = floating("global_orient"), body = floating("body_pose");
    FSKIN_CHECK(root.dim() >= 1 && body.dim() >= 1 && root.size(0) == body.size(0),
                "{}: global_orient and body_pose have different frame counts", path);
    pose = torch::cat({root.reshape({root.size(0), -1}), body.reshape({body.size(0), -1})}, 1);
  }
  FSKIN_CHECK(pose.dim() >= 1 && pose.size(0) > 0, "{}: no frames in the pose", path);
  const int64_t N = pose.size(0);
  FSKIN_CHECK(pose.numel() == N * J * 3,
              "{}: the pose has {} values per frame; the model {} has {} joints ({} values): an SMPL fit needs an "
              "SMPL model (SMPL-H / SMPL-X fits their own)",
              path, pose.numel() / N, model.num_joints(), J, 3 * J);
  CapturePoses out;
  out.axis_angle = pose.reshape({N, J, 3}).contiguous();
  out.transl = file.contains("transl") ? floating("transl") : torch::zeros({N, 3});
  expect_shape(out.transl, {N, 3}, path + ": transl");
  if (file.contains("betas")) {
    auto betas = floating("betas");
    betas = betas.dim() <= 1 ? betas.reshape({1, -1}) : betas.reshape({betas.size(0), -1})[0].reshape({1, -1});
    FSKIN_CHECK(betas.size(1) <= model.num_betas() || !betas.narrow(1, model.num_betas(), betas.size(1) - model.num_betas())
                                                          .abs()
                                                          .gt(1e-6)
                                                          .any()
                                                          .item<bool>(),
                "{}: {} betas, but the model has {} shape blend shapes", path, betas.size(1), model.num_betas());
    betas = betas.narrow(1, 0, std::min(betas.size(1), model.num_betas()));
    if (betas.size(1) > 0) out.betas = betas.contiguous();
  }
  return out;
}

// A mask as 8-bit grey (255 = subject): .npy of bools, [0, 1] floats or
// 0 / 255 bytes, or a PNG.
std::vector<uint8_t> read_mask(const std::string& stem, int width, int height) {
  if (fs::exists(stem + ".png")) {
    int w = 0, h = 0;
    auto mask = read_png_gray(stem + ".png", w, h);
    FSKIN_CHECK(w == width && h == height, "{}.png: {}x{} pixels, the image has {}x{}", stem, w, h, width, height);
    return mask;
  }
  const std::string path = stem + ".npy";
  FSKIN_CHECK(fs::exists(path), "{}.npy (or .png): missing", stem);
  auto mask = io::read_npy(path);
  FSKIN_CHECK(mask.dim() >= 2 && mask.size(0) == height && mask.size(1) == width && mask.numel() == height * width,
              "{}: shape {}, the image is {} x {} (H, W)", path, c10::str(mask.sizes()), height, width);
  auto values = mask.to(torch::kFloat64).reshape({height, width});
  expect_finite(values, path);
  const double top = values.max().item<double>(), bottom = values.min().item<double>();
  FSKIN_CHECK(bottom >= 0 && (top <= 1 || top <= 255), "{}: values in [{}, {}]; masks hold [0, 1] or [0, 255]", path,
              bottom, top);
  if (top > 1) values = values / 255.0;
  const auto bytes = (values * 255.0).round().clamp(0, 255).to(torch::kUInt8).contiguous();
  return {bytes.data_ptr<uint8_t>(), bytes.data_ptr<uint8_t>() + bytes.numel()};
}

}  // namespace

FrameRange FrameRange::parse(const std::string& text, const std::string& what) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ':');) parts.push_back(part);
  if (!text.empty() && text.back() == ':') parts.push_back("");
  FSKIN_CHECK(parts.size() >= 2 && parts.size() <= 3,
              "{}: '{}' is not a frame range (start:stop:step, start:stop or start:)", what, text);
  FrameRange r;
  r.start = parts[0].empty() ? 0 : parse_int(parts[0], what);
  r.stop = parts[1].empty() ? -1 : parse_int(parts[1], what);
  r.step = parts.size() == 3 && !parts[2].empty() ? parse_int(parts[2], what) : 1;
  FSKIN_CHECK(r.start >= 0 && r.step >= 1 && (r.stop < 0 || r.stop > r.start),
              "{}: '{}' must have start >= 0, stop > start and step >= 1", what, text);
  return r;
}

std::vector<int64_t> FrameRange::frames(int64_t count, const std::string& what) const {
  const int64_t end = stop < 0 ? count : stop;
  FSKIN_CHECK(start < count && end <= count, "{}: frames {}:{} but the capture has {} frames", what, start, end, count);
  std::vector<int64_t> out;
  for (int64_t f = start; f < end; f += step) out.push_back(f);
  return out;
}

ImageDatasetSummary import_capture(const CaptureImportOptions& options) {
  torch::NoGradGuard no_grad;
  FSKIN_CHECK(!options.out_dir.empty(), "capture import: no output directory");
  for (const double c : options.background)
    FSKIN_CHECK(c >= 0 && c <= 1, "capture import: background components must be in [0, 1], got {}", c);
  const fs::path capture(options.capture_dir);
  FSKIN_CHECK(fs::is_directory(capture), "{}: not a directory (a capture in PeopleSnapshot's layout)",
              options.capture_dir);
  const auto model = BodyModel::load(options.model_path);
  const auto poses = read_capture_poses((capture / "poses.npz").string(), model);
  const int64_t N = poses.axis_angle.size(0);

  const std::string camera_path = (capture / "cameras.npz").string();
  FSKIN_CHECK(fs::exists(camera_path), "{}: missing", camera_path);
  const auto cameras = load_cameras(camera_path, N);  // validated, one per frame
  const io::NpzReader camera_file(camera_path);
  const auto intrinsic = camera_file.tensor("intrinsic").to(torch::kFloat64);
  const auto extrinsic = camera_file.tensor("extrinsic").to(torch::kFloat64);
  const bool one_camera = intrinsic.dim() == 2 && extrinsic.dim() == 2;

  std::vector<std::pair<std::string, std::vector<int64_t>>> splits = {
      {"train", FrameRange::parse(options.train, "--train").frames(N, "--train")}};
  if (!options.novel_pose.empty())
    splits.push_back({"novel_pose", FrameRange::parse(options.novel_pose, "--novel-pose").frames(N, "--novel-pose")});

  // The shaped canonical body: the model's canonical pose with the capture's betas.
  const auto canonical_aa = canonical_pose(model, options.canonical_pose);
  const auto canonical = model.pose(canonical_aa.unsqueeze(0), poses.betas);
  RiggedMesh character;
  character.mesh = Mesh{canonical.vertices[0].contiguous(), model.data().faces, {}};
  character.weights = model.data().weights;
  character.skeleton = Skeleton{model.data().joint_names, model.data().parents, canonical.joints[0].contiguous()};

  nlohmann::json split_names = nlohmann::json::array(), ranges = nlohmann::json::object();
  nlohmann::json pose_files = nlohmann::json::object();
  for (const auto& [name, frames] : splits) {
    split_names.push_back(name);
    ranges[name] = name == "train" ? options.train : options.novel_pose;
    const auto& aligned = name == "train" ? options.train_poses : options.novel_pose_poses;
    pose_files[name] = aligned.empty() ? "poses.npz" : fs::absolute(aligned).string();
  }
  const nlohmann::json manifest = {
      {"format", "fskin-image-dataset"},
      {"format_version", kImageDatasetFormatVersion},
      {"fskin_version", FSKIN_VERSION},
      {"capture", fs::absolute(capture).string()},
      {"capture_layout", "PeopleSnapshot (InstantAvatar)"},
      {"body_model_file", fs::absolute(options.model_path).string()},
      {"frame_ranges", ranges},
      {"pose_files", pose_files},
      {"betas", poses.betas.defined() ? std::vector<float>(poses.betas.data_ptr<float>(),
                                                           poses.betas.data_ptr<float>() + poses.betas.numel())
                                      : std::vector<float>{}},
      {"num_joints", model.num_joints()},
      {"joint_names", model.data().joint_names},
      {"parents", model.data().parents},
      {"canonical_pose", resolve_canonical_pose(model, options.canonical_pose)},
      {"canonical_pose_option", options.canonical_pose},
      {"background", options.background},
      {"splits", split_names},
  };
  const fs::path dir(options.out_dir);
  const BuildManifest build_manifest(options.out_dir, manifest);
  save_canonical_character(character, (dir / "canonical.npz").string());

  ImageDatasetSummary summary;
  for (const auto& [split, frames] : splits) {
    const fs::path split_dir = dir / split;
    create_output_directory((split_dir / "images").string());
    create_output_directory((split_dir / "masks").string());
    const auto index = torch::tensor(frames, torch::kInt64);
    const auto& aligned_path = split == "train" ? options.train_poses : options.novel_pose_poses;
    torch::Tensor axis_angle, transl;
    if (aligned_path.empty()) {
      axis_angle = poses.axis_angle.index_select(0, index);
      transl = poses.transl.index_select(0, index);
    } else {
      const auto aligned = read_capture_poses(aligned_path, model);
      FSKIN_CHECK(aligned.axis_angle.size(0) == index.size(0), "{}: {} poses, but the {} split has {} frames",
                  aligned_path, aligned.axis_angle.size(0), split, index.size(0));
      axis_angle = aligned.axis_angle;
      transl = aligned.transl;
    }
    const auto posed = model.pose(axis_angle, poses.betas.defined() ? poses.betas.expand({index.size(0), -1})
                                                                     : torch::Tensor(),
                                  transl);
    const auto bones = relative_bone_transforms(posed.bone_transforms, canonical.bone_transforms);
    io::NpzWriter pose_file;
    pose_file.add("bone_transforms", bones.to(torch::kFloat32).contiguous());
    pose_file.add("pose_index", index);
    pose_file.add("view_index", torch::zeros({index.size(0)}, torch::kInt64));
    pose_file.save((split_dir / "poses.npz").string());
    io::NpzWriter split_cameras;
    split_cameras.add("intrinsic", one_camera ? intrinsic.contiguous() : intrinsic.index_select(0, index).contiguous());
    split_cameras.add("extrinsic", one_camera ? extrinsic.contiguous() : extrinsic.index_select(0, index).contiguous());
    split_cameras.add("height", torch::tensor(int64_t{cameras[0].height}));
    split_cameras.add("width", torch::tensor(int64_t{cameras[0].width}));
    split_cameras.save((split_dir / "cameras.npz").string());

    ProgressBar progress("importing " + split, static_cast<int64_t>(frames.size()), options.progress);
    for (size_t k = 0; k < frames.size(); ++k) {
      const auto image_out = split_dir / "images" / image_file_name(static_cast<int64_t>(k));
      const auto mask_out = split_dir / "masks" / mask_file_name(static_cast<int64_t>(k));
      if (fs::exists(image_out) && fs::exists(mask_out)) {
        ++summary.images_skipped;
        progress.advance(1);
        continue;
      }
      const int64_t f = frames[k];
      const auto image_in = (capture / "images" / image_file_name(f)).string();
      FSKIN_CHECK(fs::exists(image_in), "{}: missing (poses.npz has {} frames)", image_in, N);
      Image image = read_png(image_in);
      FSKIN_CHECK(image.width == cameras[f].width && image.height == cameras[f].height,
                  "{}: {}x{} pixels, but {} says {}x{}", image_in, image.width, image.height, camera_path,
                  cameras[f].width, cameras[f].height);
      const std::string stem = (capture / "masks" / mask_file_name(f)).replace_extension().string();
      const auto mask = read_mask(stem, image.width, image.height);
      // The photograph over one colour, by its mask: what the avatar renders over.
      for (size_t p = 0; p < mask.size(); ++p) {
        const double alpha = mask[p] / 255.0;
        for (int c = 0; c < 3; ++c) {
          uint8_t& v = image.rgb[3 * p + c];
          v = static_cast<uint8_t>(std::lround(alpha * v + (1 - alpha) * 255.0 * options.background[c]));
        }
      }
      write_png_gray(mask_out.string(), image.width, image.height, mask);
      write_png(image_out.string(), image);
      ++summary.images_written;
      progress.advance(1);
    }
    progress.finish();
    (split == "train" ? summary.train : summary.novel_pose) = static_cast<int64_t>(frames.size());
  }
  build_manifest.mark_complete();
  return summary;
}

}  // namespace fskin
