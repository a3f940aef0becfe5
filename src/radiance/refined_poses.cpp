#include "fskin/radiance/refined_poses.h"

#include <torch/torch.h>

#include <cmath>
#include <filesystem>
#include <optional>

#include <fmt/format.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/image_dataset.h"

namespace fskin {

std::string RefinedPoses::to_string() const {
  std::string out = fmt::format("{} training frames; mean correction {:.2f} degrees per joint, root shift {:.4f} of the size",
                                given.defined() ? given.size(0) : 0, mean_rotation_degrees, mean_root_shift);
  if (exact.defined()) {
    out += fmt::format(
        "\nagainst the exact poses: given {:.2f} degrees per joint, joints {:.4f} of the size off; refined {:.2f} "
        "degrees, {:.4f}",
        given_error.rotation_degrees, given_error.joint_distance, refined_error.rotation_degrees,
        refined_error.joint_distance);
  }
  return out;
}

void RefinedPoses::save(const std::string& path) const {
  io::NpzWriter writer;
  writer.add("given_bone_transforms", given.contiguous());
  writer.add("bone_transforms", refined.contiguous());
  if (exact.defined()) writer.add("bone_transforms_exact", exact.contiguous());
  writer.save(path);
}

RefinedPoses refined_poses(const std::string& run_dir) {
  torch::NoGradGuard no_grad;
  auto trained = TrainedAvatar::load(run_dir);
  FSKIN_CHECK(trained.corrections, "{}: the run does not refine poses (train with --refine-poses)", run_dir);
  return refined_poses(*trained.corrections, trained.skeleton, trained.size, trained.options.data_dir, run_dir);
}

RefinedPoses refined_poses(const PoseCorrectionsImpl& corrections, const Skeleton& skeleton, double size,
                           const std::string& data_dir, const std::string& run_dir) {
  torch::NoGradGuard no_grad;
  RefinedPoses out;
  out.given = corrections.given_bones();
  out.refined = corrections.corrected(skeleton, size);
  if (corrections.frames() > 0) {
    out.mean_rotation_degrees = corrections.rotations().norm(2, -1).mean().item<double>() * 180.0 / M_PI;
    out.mean_root_shift = corrections.translations().norm(2, -1).mean().item<double>();
  }
  const auto pose_path = (std::filesystem::path(data_dir) / "train" / "poses.npz").string();
  const auto file = std::filesystem::exists(pose_path) ? std::make_optional<io::NpzReader>(pose_path) : std::nullopt;
  if (file && file->contains("bone_transforms_exact")) {
    const auto given = load_bone_transforms(pose_path, skeleton.num_joints());
    const auto exact = file->tensor("bone_transforms_exact").to(torch::kFloat32);
    FSKIN_CHECK(exact.sizes() == given.sizes(), "{}: bone_transforms_exact is {}, bone_transforms {}", pose_path,
                shape_string(exact.sizes()), shape_string(given.sizes()));
    std::vector<torch::Tensor> rows;
    for (int64_t f = 0; f < corrections.frames(); ++f) {
      int64_t image = -1;
      for (int64_t i = 0; i < given.size(0) && image < 0; ++i) {
        if (torch::equal(given[i], out.given[f])) image = i;
      }
      FSKIN_CHECK(image >= 0, "{}: frame {} of run {} is not in this file (was the dataset changed?)", pose_path, f,
                  run_dir);
      rows.push_back(exact[image]);
    }
    out.exact = torch::stack(rows);
    out.given_error = pose_error(out.given, out.exact, skeleton, size);
    out.refined_error = pose_error(out.refined, out.exact, skeleton, size);
  }
  return out;
}

}  // namespace fskin
