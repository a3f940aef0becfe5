#include "fskin/radiance/pose_perturbation.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include <fmt/format.h>

#include "fskin/core/error.h"
#include "fskin/geometry/character_size.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/pose_correction.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

constexpr const char* kPerturbedSplits[] = {"train", "novel_view"};

}  // namespace

void PosePerturbationOptions::validate() const {
  FSKIN_CHECK(!data_dir.empty() && !out_dir.empty(), "data perturb-poses: --data and --out are required");
  FSKIN_CHECK(std::isfinite(degrees) && degrees >= 0 && degrees <= 90,
              "data perturb-poses: degrees must be within [0, 90], got {}", degrees);
  FSKIN_CHECK(std::isfinite(translation) && translation >= 0 && translation <= 1,
              "data perturb-poses: the translation must be within [0, 1] (of the character's size), got {}",
              translation);
}

std::string PosePerturbationSummary::to_string() const {
  return fmt::format("{} poses perturbed: {:.2f} degrees per joint on average, posed joints moved {:.4f} of the size",
                     frames, rotation_degrees, joint_distance);
}

PosePerturbationSummary perturb_image_dataset_poses(const PosePerturbationOptions& options) {
  options.validate();
  torch::NoGradGuard no_grad;
  const ImageDataset data(options.data_dir);  // validates the manifest and the character
  const fs::path in(options.data_dir), out(options.out_dir);
  FSKIN_CHECK(!fs::exists(out) || fs::is_empty(out), "{}: exists and is not empty; choose a new --out", out.string());
  std::error_code same;
  FSKIN_CHECK(!fs::exists(out) || !fs::equivalent(in, out, same), "data perturb-poses: --out is --data");
  fs::create_directories(out);
  fs::copy(in, out, fs::copy_options::recursive | fs::copy_options::overwrite_existing);

  const auto& character = data.character();
  const auto& skeleton = character.skeleton;
  const int64_t J = character.num_joints();
  const double size = character_size(character.mesh.vertices, "data perturb-poses: canonical vertices");
  auto generator = at::make_generator<at::CPUGeneratorImpl>(options.seed);
  // One noise per distinct pose of the perturbed splits (the novel views of a
  // training pose share its noise), drawn in the order the poses first appear.
  std::vector<torch::Tensor> exact_poses;
  std::vector<std::pair<std::string, torch::Tensor>> split_poses;  // each perturbed split's exact bones
  const auto splits = data.split_names();
  for (const char* split : kPerturbedSplits) {
    if (std::find(splits.begin(), splits.end(), split) == splits.end()) continue;
    const auto bones = load_bone_transforms((out / split / "poses.npz").string(), J);
    split_poses.emplace_back(split, bones);
    for (int64_t i = 0; i < bones.size(0); ++i) {
      bool seen = false;
      for (const auto& pose : exact_poses) seen = seen || torch::equal(pose, bones[i]);
      if (!seen) exact_poses.push_back(bones[i]);
    }
  }
  FSKIN_CHECK(!exact_poses.empty(), "{}: no train or novel_view poses to perturb", options.data_dir);
  const auto F = static_cast<int64_t>(exact_poses.size());
  const auto unit = [](const torch::Tensor& v) { return v / v.norm(2, -1, true).clamp_min(1e-12); };
  auto rotations = unit(at::randn({F, J, 3}, generator, c10::kDouble)) * (options.degrees * M_PI / 180.0);
  auto shifts = unit(at::randn({F, 3}, generator, c10::kDouble)) * options.translation;
  // Zero-mean over the poses (an unbiased pose source): a common part would
  // move the whole set into another frame, which no refinement can tell from
  // the canonical shape (PoseCorrectionsImpl::center).
  if (F > 1) {
    rotations = rotations - rotations.mean(0, true);
    shifts = shifts - shifts.mean(0, true);
  }
  rotations = rotations.to(torch::kFloat32);
  shifts = shifts.to(torch::kFloat32);
  // Every pose of the splits is among exact_poses (collected above).
  const auto noise_of = [&](const torch::Tensor& bones) {
    int64_t f = 0;
    while (f + 1 < F && !torch::equal(exact_poses[f], bones)) ++f;
    return f;
  };

  PosePerturbationSummary summary;
  std::vector<torch::Tensor> all_perturbed, all_exact;
  for (const auto& [split, exact] : split_poses) {
    const auto path = (out / split / "poses.npz").string();
    const io::NpzReader reader(path);
    FSKIN_CHECK(!reader.contains("bone_transforms_exact"),
                "{}: already perturbed (it has bone_transforms_exact); perturb the original dataset", path);
    auto perturbed = exact.clone();
    for (int64_t i = 0; i < exact.size(0); ++i) {
      const int64_t f = noise_of(exact[i]);
      perturbed[i].copy_(corrected_bone_transforms(exact[i], rotations[f], shifts[f], skeleton, size));
    }
    io::NpzWriter writer;
    for (const auto& key : reader.keys()) {
      if (key != "bone_transforms") writer.add(key, reader.tensor(key));
    }
    writer.add("bone_transforms", perturbed.contiguous());
    writer.add("bone_transforms_exact", exact.contiguous());
    writer.save(path);
    all_perturbed.push_back(perturbed);
    all_exact.push_back(exact);
  }
  summary.frames = F;
  const auto error = pose_error(torch::cat(all_perturbed), torch::cat(all_exact), skeleton, size);
  summary.rotation_degrees = error.rotation_degrees;
  summary.joint_distance = error.joint_distance;
  return summary;
}

}  // namespace fskin
