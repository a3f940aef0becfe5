#include "fskin/radiance/pose_correction.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {

torch::Tensor corrected_bone_transforms(const torch::Tensor& bones, const torch::Tensor& rotations,
                                        const torch::Tensor& translation, const Skeleton& skeleton, double size) {
  const int64_t J = skeleton.num_joints();
  FSKIN_CHECK(bones.dim() >= 3 && bones.size(-3) == J && bones.size(-2) == 4 && bones.size(-1) == 4,
              "pose correction: bones must be [..., {}, 4, 4], got {}", J, shape_string(bones.sizes()));
  FSKIN_CHECK(rotations.dim() == bones.dim() - 1 && rotations.size(-2) == J && rotations.size(-1) == 3,
              "pose correction: rotations must be [..., {}, 3], got {}", J, shape_string(rotations.sizes()));
  FSKIN_CHECK(translation.dim() == bones.dim() - 2 && translation.size(-1) == 3,
              "pose correction: the translation must be [..., 3], got {}", shape_string(translation.sizes()));
  FSKIN_CHECK(std::isfinite(size) && size > 0, "pose correction: size must be positive, got {}", size);
  const auto options = bones.options();
  const auto centres = skeleton.rest_joints.to(options);  // [J, 3]
  // M_j = T(c_j) R_j T(-c_j): [R_j | c_j - R_j c_j].
  const auto R = axis_angle_to_matrix(rotations.to(options));  // [..., J, 3, 3]
  const auto shift = centres - torch::matmul(R, centres.unsqueeze(-1)).squeeze(-1);
  auto bottom_shape = R.sizes().vec();
  bottom_shape[bottom_shape.size() - 2] = 1;
  bottom_shape[bottom_shape.size() - 1] = 4;
  auto bottom = torch::zeros(bottom_shape, options);
  bottom.select(-1, 3).fill_(1);
  const auto M = torch::cat({torch::cat({R, shift.unsqueeze(-1)}, -1), bottom}, -2);
  auto lift = torch::zeros(bones.select(-3, 0).sizes(), options);
  lift = lift + torch::eye(4, options);
  lift.narrow(-2, 0, 3).select(-1, 3).copy_(translation.to(options) * size);
  const auto inverse = invert_transforms(bones.detach());
  std::vector<torch::Tensor> corrected(static_cast<size_t>(J)), correction(static_cast<size_t>(J));
  for (int64_t j = 0; j < J; ++j) {
    const int64_t p = skeleton.parents[static_cast<size_t>(j)];
    const auto left = p < 0 ? lift : correction[static_cast<size_t>(p)];
    corrected[j] = torch::matmul(left, torch::matmul(bones.select(-3, j), M.select(-3, j)));
    correction[j] = torch::matmul(corrected[j], inverse.select(-3, j));
  }
  return torch::stack(corrected, -3);
}

PoseCorrectionsImpl::PoseCorrectionsImpl(const torch::Tensor& given_bones) {
  expect_shape(given_bones, {-1, -1, 4, 4}, "pose corrections: given bones");
  const int64_t frames = given_bones.size(0), joints = given_bones.size(1);
  given_ = register_buffer("given_bones", given_bones.detach().to(torch::kFloat32).clone());
  for (int64_t f = 0; f < frames; ++f) {
    rotations_.push_back(register_parameter("rotations_" + std::to_string(f), torch::zeros({joints, 3})));
    translations_.push_back(register_parameter("translation_" + std::to_string(f), torch::zeros({3})));
  }
}

std::shared_ptr<PoseCorrectionsImpl> PoseCorrectionsImpl::read(torch::serialize::InputArchive& archive) {
  torch::Tensor given;
  FSKIN_CHECK(archive.try_read("given_bones", given, /*is_buffer=*/true), "pose corrections: no given_bones saved");
  auto module = std::make_shared<PoseCorrectionsImpl>(given);
  module->load(archive);
  return module;
}

torch::Tensor PoseCorrectionsImpl::apply(int64_t frame, const Skeleton& skeleton, double size) const {
  FSKIN_CHECK(frame >= 0 && frame < frames(), "pose corrections: frame {} of {}", frame, frames());
  return corrected_bone_transforms(given_[frame], rotations_[frame], translations_[frame], skeleton, size);
}

torch::Tensor PoseCorrectionsImpl::corrected(const Skeleton& skeleton, double size) const {
  torch::NoGradGuard no_grad;
  return corrected_bone_transforms(given_, rotations(), translations(), skeleton, size);
}

int64_t PoseCorrectionsImpl::find(const torch::Tensor& bones) const { return find_frame(given_, bones); }

torch::Tensor PoseCorrectionsImpl::bones_for(const torch::Tensor& given, const Skeleton& skeleton, double size) const {
  const int64_t frame = find(given);
  return frame < 0 ? given : apply(frame, skeleton, size).detach();
}

torch::Tensor PoseCorrectionsImpl::squared_size(const std::vector<int64_t>& frames) const {
  auto total = torch::zeros({});
  for (const int64_t f : frames) total = total + rotations_[f].pow(2).sum() + translations_[f].pow(2).sum();
  return frames.empty() ? total : total / static_cast<double>(frames.size());
}

void PoseCorrectionsImpl::forget_gradients() {
  for (auto& p : rotations_) p.mutable_grad() = torch::Tensor();
  for (auto& p : translations_) p.mutable_grad() = torch::Tensor();
}

void PoseCorrectionsImpl::center() {
  if (frames() == 0) return;
  torch::NoGradGuard no_grad;
  const auto mean_rotation = rotations().mean(0), mean_translation = translations().mean(0);
  for (auto& p : rotations_) p.sub_(mean_rotation);
  for (auto& p : translations_) p.sub_(mean_translation);
}

void PoseCorrectionsImpl::assign(const PoseCorrectionsImpl& other) {
  FSKIN_CHECK(other.given_.sizes() == given_.sizes() && torch::equal(other.given_, given_),
              "pose corrections: the corrections assigned correct other bones ({} frames against {})", other.frames(),
              frames());
  torch::NoGradGuard no_grad;
  for (size_t f = 0; f < rotations_.size(); ++f) {
    rotations_[f].copy_(other.rotations_[f]);
    translations_[f].copy_(other.translations_[f]);
  }
}

torch::Tensor PoseCorrectionsImpl::rotations() const {
  const int64_t J = given_.size(1);
  return rotations_.empty() ? torch::zeros({0, J, 3}) : torch::stack(rotations_).detach();
}

torch::Tensor PoseCorrectionsImpl::translations() const {
  return translations_.empty() ? torch::zeros({0, 3}) : torch::stack(translations_).detach();
}

torch::Tensor frame_bone_transforms(const torch::Tensor& bone_transforms, const std::vector<int64_t>& frame_of) {
  const int64_t frames = frame_of.empty() ? 0 : *std::max_element(frame_of.begin(), frame_of.end()) + 1;
  std::vector<int64_t> first(static_cast<size_t>(frames), -1);
  for (size_t i = 0; i < frame_of.size(); ++i) {
    if (first[frame_of[i]] < 0) first[frame_of[i]] = static_cast<int64_t>(i);
  }
  return bone_transforms.index_select(0, torch::tensor(first, torch::kInt64));
}

std::vector<int64_t> frames_of_images(const torch::Tensor& bone_transforms) {
  const int64_t n = bone_transforms.size(0);
  std::vector<int64_t> frame(static_cast<size_t>(n)), first_image;
  for (int64_t i = 0; i < n; ++i) {
    frame[i] = -1;
    for (size_t f = 0; f < first_image.size(); ++f) {
      if (torch::equal(bone_transforms[i], bone_transforms[first_image[f]])) {
        frame[i] = static_cast<int64_t>(f);
        break;
      }
    }
    if (frame[i] < 0) {
      frame[i] = static_cast<int64_t>(first_image.size());
      first_image.push_back(i);
    }
  }
  return frame;
}

int64_t find_frame(const torch::Tensor& frame_bones, const torch::Tensor& bones) {
  const auto b = bones.to(frame_bones.scalar_type());
  for (int64_t f = 0; f < frame_bones.size(0); ++f) {
    if (torch::equal(frame_bones[f], b)) return f;
  }
  return -1;
}

PoseError pose_error(const torch::Tensor& bones, const torch::Tensor& reference, const Skeleton& skeleton,
                     double size) {
  torch::NoGradGuard no_grad;
  const int64_t J = skeleton.num_joints();
  expect_shape(bones, {-1, J, 4, 4}, "pose error: bones");
  FSKIN_CHECK(reference.sizes() == bones.sizes(), "pose error: reference bones {} for bones {}",
              shape_string(reference.sizes()), shape_string(bones.sizes()));
  const auto a = bones.to(torch::kFloat64), b = reference.to(torch::kFloat64);
  // Each joint's rotation relative to its parent's (the root's own): R_p^T R_j.
  const auto local = [&skeleton](const torch::Tensor& bones_) {
    const auto R = bones_.narrow(-2, 0, 3).narrow(-1, 0, 3);
    std::vector<torch::Tensor> rows;
    for (int64_t j = 0; j < skeleton.num_joints(); ++j) {
      const int64_t p = skeleton.parents[static_cast<size_t>(j)];
      rows.push_back(p < 0 ? R.select(-3, j) : torch::matmul(R.select(-3, p).transpose(-1, -2), R.select(-3, j)));
    }
    return torch::stack(rows, -3);
  };
  const auto relative = torch::matmul(local(a), local(b).transpose(-1, -2));
  const auto cosine = ((relative.diagonal(0, -2, -1).sum(-1) - 1) / 2).clamp(-1, 1);
  const auto c = torch::cat({skeleton.rest_joints.to(torch::kFloat64), torch::ones({J, 1}, torch::kFloat64)}, 1);
  const auto posed_a = torch::matmul(a, c.unsqueeze(-1)).squeeze(-1).narrow(-1, 0, 3);
  const auto posed_b = torch::matmul(b, c.unsqueeze(-1)).squeeze(-1).narrow(-1, 0, 3);
  PoseError out;
  if (bones.size(0) == 0) return out;
  out.rotation_degrees = torch::acos(cosine).mean().item<double>() * 180.0 / M_PI;
  out.joint_distance = (posed_a - posed_b).norm(2, -1).mean().item<double>() / size;
  return out;
}

}  // namespace fskin
