#include "fskin/deformers/snarf_deformer.h"

#include "fskin/core/error.h"
#include "fskin/ops/broyden_lanes.h"
#include "fskin/skeleton/lbs.h"

namespace fskin {

SnarfDeformer::SnarfDeformer(std::shared_ptr<SkinningField> field, DeformerOptions options)
    : Deformer(std::move(options)), field_(std::move(field)) {
  FSKIN_CHECK(field_ != nullptr, "SnarfDeformer: no skinning field");
}

torch::Tensor SnarfDeformer::deform_prepared(int64_t b, const torch::Tensor& x) {
  // d(x) = sum_j w_j(x) B_j x (eq. 4) with the field queried at x.
  const auto w = field_->weights(x).to(x.dtype());  // [M, J]
  return linear_blend_skinning(x.unsqueeze(0), w.unsqueeze(0), bones_.narrow(0, b, 1)).squeeze(0);
}

Deformer::SearchResult SnarfDeformer::search(const torch::Tensor& x_posed, const torch::Tensor& start_inverses,
                                             bool need_inverse_jacobian) {
  const int64_t B = x_posed.size(0), n = x_posed.size(1), S = start_inverses.size(1);
  const int64_t I = options_.start_bones.slots(field_->num_bones());
  const auto solver = search_options();
  SearchResult out;
  out.x = torch::empty({B, n, I, 3}, x_posed.options());
  out.valid = torch::zeros({B, n, I}, x_posed.options().dtype(torch::kBool));
  out.iterations = torch::zeros({B, n, I}, x_posed.options().dtype(torch::kUInt8));
  if (need_inverse_jacobian) out.inverse_jacobian = torch::empty({B, n, I, 3, 3}, x_posed.options());
  for (int64_t b = 0; b < B; ++b) {
    const auto xp = x_posed[b];                                                    // [n, 3]
    auto x0 = transform_points(start_inverses[b].unsqueeze(0), xp.unsqueeze(1));  // [n, S, 3]
    const auto target = xp.unsqueeze(1).expand({n, I, 3}).reshape({-1, 3});
    if (I < S) {
      // The automatic start rule, on the MLP's own weight of each start at its rigid start.
      const auto w = field_->weights(x0).to(x0.dtype());  // [n, S, J]; all bones are candidates
      const auto order = rank_starts(w.diagonal(0, 1, 2), I);
      x0 = x0.gather(1, order.unsqueeze(-1).expand({n, I, 3}));
    }
    const auto x = x0.reshape({-1, 3});
    // Exact initial Jacobians (eq. 7), then the shared solver with residuals from the MLP.
    auto lanes = start_broyden_lanes(x, deform_prepared(b, x) - target, spatial_jacobian(b, x));
    for (int k = 0;; ++k) {
      const auto stepped = step_broyden_lanes(lanes, k, solver);
      if (stepped.numel() == 0) break;
      const auto residual = deform_prepared(b, lanes.x.index_select(0, stepped)) - target.index_select(0, stepped);
      update_broyden_lanes(lanes, stepped, residual, solver);
    }
    out.x[b] = lanes.x.reshape({n, I, 3});
    out.valid[b] = (lanes.state == kLaneConverged).reshape({n, I});
    out.iterations[b] = lanes.iterations.reshape({n, I});
    if (need_inverse_jacobian) out.inverse_jacobian[b] = lanes.inverse_jacobian.reshape({n, I, 3, 3});
  }
  return out;
}

}  // namespace fskin
