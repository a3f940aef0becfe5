#include "fskin/radiance/appearance_codes.h"

#include <string>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/radiance/pose_correction.h"

namespace fskin {

AppearanceCodesImpl::AppearanceCodesImpl(const torch::Tensor& given_bones, int64_t dim) : dim_(dim) {
  expect_shape(given_bones, {-1, -1, 4, 4}, "appearance codes: given bones");
  FSKIN_CHECK(dim >= 1 && dim <= 1024, "appearance codes: the code length must be within 1..1024, got {}", dim);
  given_ = register_buffer("given_bones", given_bones.detach().to(torch::kFloat32).clone());
  for (int64_t f = 0; f < frames(); ++f)
    codes_.push_back(register_parameter("code_" + std::to_string(f), 0.01 * torch::randn({dim})));
  center();
}

std::shared_ptr<AppearanceCodesImpl> AppearanceCodesImpl::read(torch::serialize::InputArchive& archive) {
  torch::Tensor given, first;
  FSKIN_CHECK(archive.try_read("given_bones", given, /*is_buffer=*/true), "appearance codes: no given_bones saved");
  FSKIN_CHECK(given.size(0) == 0 || archive.try_read("code_0", first), "appearance codes: no codes saved");
  auto module = std::make_shared<AppearanceCodesImpl>(given, given.size(0) == 0 ? 1 : first.size(0));
  module->load(archive);
  return module;
}

const torch::Tensor& AppearanceCodesImpl::code(int64_t frame) const {
  FSKIN_CHECK(frame >= 0 && frame < frames(), "appearance codes: frame {} of {}", frame, frames());
  return codes_[frame];
}

torch::Tensor AppearanceCodesImpl::code_for(const torch::Tensor& bones) const {
  const int64_t frame = find_frame(given_, bones);
  return frame < 0 ? torch::Tensor() : codes_[frame].detach();
}

void AppearanceCodesImpl::forget_gradients() {
  for (auto& p : codes_) p.mutable_grad() = torch::Tensor();
}

void AppearanceCodesImpl::center() {
  if (frames() == 0) return;
  torch::NoGradGuard no_grad;
  const auto mean = codes().mean(0);
  for (auto& p : codes_) p.sub_(mean);
}

torch::Tensor AppearanceCodesImpl::codes() const {
  return codes_.empty() ? torch::zeros({0, dim_}) : torch::stack(codes_).detach();
}

}  // namespace fskin
