#include "fskin/gaussians/density_control.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "fskin/core/error.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {

void DensityControlOptions::validate() const {
  FSKIN_CHECK(start >= 0 && every >= 1, "gaussian density control: start must be >= 0 and every >= 1");
  FSKIN_CHECK(stop_fraction >= 0 && stop_fraction <= 1,
              "gaussian density control: stop_fraction must be within [0, 1], got {}", stop_fraction);
  FSKIN_CHECK(std::isfinite(gradient_threshold) && gradient_threshold > 0,
              "gaussian density control: the gradient threshold must be > 0, got {}", gradient_threshold);
  FSKIN_CHECK(dense_fraction > 0 && max_scale_fraction > dense_fraction,
              "gaussian density control: need 0 < dense_fraction < max_scale_fraction, got {} and {}", dense_fraction,
              max_scale_fraction);
  FSKIN_CHECK(std::isfinite(max_scale_spacings) && max_scale_spacings >= 0,
              "gaussian density control: max_scale_spacings must be >= 0 (0: no bound), got {}", max_scale_spacings);
  FSKIN_CHECK(min_opacity >= 0 && min_opacity < 1, "gaussian density control: min_opacity must be within [0, 1)");
  FSKIN_CHECK(opacity_reset_every >= 0 && max_gaussians >= 1,
              "gaussian density control: opacity_reset_every must be >= 0 and max_gaussians >= 1");
}

void DensityStatistics::reset(int64_t gaussians) {
  sum_ = torch::zeros({gaussians}, torch::kFloat32);
  count_ = torch::zeros({gaussians}, torch::kFloat32);
}

void DensityStatistics::add(const torch::Tensor& means2d_grad, const torch::Tensor& radii, int64_t width,
                            int64_t height) {
  FSKIN_CHECK(means2d_grad.size(0) == size() && radii.size(0) == size(),
              "gaussian density control: statistics of {} Gaussians given {}", size(), means2d_grad.size(0));
  // d/d(ndc) = d/d(pixel) x (size / 2): 3DGS's threshold is in those units.
  const auto scale = torch::tensor({0.5 * static_cast<double>(width), 0.5 * static_cast<double>(height)},
                                   torch::kFloat32);
  const auto norm = (means2d_grad.detach().to(torch::kFloat32).cpu() * scale).norm(2, 1);
  const auto drawn = (radii.detach().cpu() > 0).to(torch::kFloat32);
  sum_ += norm * drawn;
  count_ += drawn;
}

void DensityStatistics::restore(torch::Tensor sum, torch::Tensor count) {
  FSKIN_CHECK(sum.dim() == 1 && count.sizes() == sum.sizes(),
              "gaussian density control: the statistics' sums and counts disagree");
  sum_ = sum.to(torch::kFloat32).contiguous();
  count_ = count.to(torch::kFloat32).contiguous();
}

torch::Tensor DensityStatistics::mean_gradient() const { return sum_ / count_.clamp_min(1); }

namespace {

constexpr size_t kParameters = 9;  // the surface weights and anchors take no optimiser

std::array<torch::Tensor*, kParameters> gaussian_parameters(GaussianAvatarImpl& avatar) {
  return {&avatar.means(),          &avatar.log_scales(), &avatar.rotations(),      &avatar.opacity_logits(),
          &avatar.sh_dc(),          &avatar.sh_rest(),    &avatar.surface_weights(), &avatar.skinning_corrections(),
          &avatar.surface_anchors()};
}

torch::optim::AdamParamState* adam_state(torch::optim::Adam& adam, const torch::Tensor& parameter) {
  auto& states = adam.state();
  const auto found = states.find(c10::guts::to_string(parameter.unsafeGetTensorImpl()));
  return found == states.end() ? nullptr : static_cast<torch::optim::AdamParamState*>(found->second.get());
}

// Every parameter becomes its rows `kept` followed by `added` (one tensor per
// parameter, in gaussian_parameters' order); Adam's moments alike, zero for
// the added rows.
void edit_gaussians(GaussianAvatarImpl& avatar, torch::optim::Adam& adam, const torch::Tensor& kept,
                    const std::array<torch::Tensor, kParameters>& added) {
  const auto parameters = gaussian_parameters(avatar);
  std::array<torch::Tensor, kParameters> values;
  for (size_t k = 0; k < parameters.size(); ++k) {
    const auto& p = *parameters[k];
    values[k] = torch::cat({p.detach().index_select(0, kept), added[k].to(p.options())});
    if (auto* state = adam_state(adam, p)) {
      const auto extend = [&](const torch::Tensor& moment) {
        return torch::cat({moment.index_select(0, kept), torch::zeros_like(added[k], moment.options())});
      };
      state->exp_avg(extend(state->exp_avg()));
      state->exp_avg_sq(extend(state->exp_avg_sq()));
      if (state->max_exp_avg_sq().defined()) state->max_exp_avg_sq(extend(state->max_exp_avg_sq()));
    }
  }
  avatar.replace_gaussians(values[0], values[1], values[2], values[3], values[4], values[5], values[6],
                           values[7], values[8]);
}

// The rows `index` of every parameter, in gaussian_parameters' order.
std::array<torch::Tensor, kParameters> rows(GaussianAvatarImpl& avatar, const torch::Tensor& index) {
  const auto parameters = gaussian_parameters(avatar);
  std::array<torch::Tensor, kParameters> out;
  for (size_t k = 0; k < parameters.size(); ++k) out[k] = parameters[k]->detach().index_select(0, index);
  return out;
}

}  // namespace

DensityChange densify_and_prune(GaussianAvatarImpl& avatar, const DensityStatistics& statistics,
                                torch::optim::Adam& adam, const DensityControlOptions& options, double size) {
  torch::NoGradGuard no_grad;
  const int64_t n = avatar.size();
  FSKIN_CHECK(statistics.size() == n, "gaussian density control: statistics of {} Gaussians for {}",
              statistics.size(), n);
  const auto scales = torch::exp(avatar.log_scales().detach());
  const auto widest = std::get<0>(scales.max(1));
  const auto opacity = torch::sigmoid(avatar.opacity_logits().detach());
  auto prune = (opacity < options.min_opacity) | (widest > options.max_scale_fraction * size);
  if (options.max_scale_spacings > 0) prune = prune | (widest > options.max_scale_spacings * avatar.initial_spacing());
  auto grow = (statistics.mean_gradient() >= options.gradient_threshold) & ~prune;
  // Growth within max_gaussians: a split adds one Gaussian net, a clone one;
  // when there is no room for all, the largest gradients go first.
  const int64_t room = std::max<int64_t>(0, options.max_gaussians - n);
  const auto candidates = torch::nonzero(grow).view({-1});
  if (candidates.size(0) > room) {
    const auto order = std::get<1>(torch::sort(statistics.mean_gradient().index_select(0, candidates),
                                               /*stable=*/true, 0, /*descending=*/true));
    grow = torch::zeros_like(grow);
    grow.index_fill_(0, candidates.index_select(0, order.narrow(0, 0, room)), true);
  }
  const auto small = widest <= options.dense_fraction * size;
  const auto clone_index = torch::nonzero(grow & small).view({-1});
  const auto split_index = torch::nonzero(grow & ~small).view({-1});

  // Clones: exact copies (the gradient steps pull the pair apart).
  const auto clones = rows(avatar, clone_index);
  // Splits: two Gaussians drawn from the original, 1.6 times narrower.
  auto halves = rows(avatar, split_index.repeat({2}));
  {
    const auto parent_scales = torch::exp(halves[1]);
    const auto rotation = quaternion_to_matrix(halves[2] / halves[2].norm(2, 1, true).clamp_min(1e-12));
    const auto offsets = torch::matmul(rotation, (torch::randn_like(parent_scales) * parent_scales).unsqueeze(-1));
    halves[0] = halves[0] + offsets.squeeze(-1);
    halves[1] = torch::log(parent_scales / 1.6);
  }
  std::array<torch::Tensor, kParameters> added;
  for (size_t k = 0; k < added.size(); ++k) added[k] = torch::cat({clones[k], halves[k]});
  auto keep = ~prune;
  keep.index_fill_(0, split_index, false);
  edit_gaussians(avatar, adam, torch::nonzero(keep).view({-1}), added);
  DensityChange change;
  change.cloned = clone_index.size(0);
  change.split = split_index.size(0);
  change.pruned = prune.sum().item<int64_t>();
  return change;
}

void reset_opacities(GaussianAvatarImpl& avatar, torch::optim::Adam& adam, double ceiling) {
  torch::NoGradGuard no_grad;
  auto& logits = avatar.opacity_logits();
  logits.clamp_max_(std::log(ceiling / (1 - ceiling)));
  if (auto* state = adam_state(adam, logits)) {
    state->exp_avg(torch::zeros_like(state->exp_avg()));
    state->exp_avg_sq(torch::zeros_like(state->exp_avg_sq()));
  }
}

}  // namespace fskin
