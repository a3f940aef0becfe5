#include "fskin/deformers/snarf_deformer.h"

#include "fskin/core/error.h"
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
  SearchResult out;
  out.x = torch::empty({B, n, I, 3}, x_posed.options());
  out.valid = torch::zeros({B, n, I}, x_posed.options().dtype(torch::kBool));
  out.iterations = torch::zeros({B, n, I}, x_posed.options().dtype(torch::kInt32));
  if (need_inverse_jacobian) out.inverse_jacobian = torch::empty({B, n, I, 3, 3}, x_posed.options());
  for (int64_t b = 0; b < B; ++b) {
    const auto xp = x_posed[b];                                                    // [n, 3]
    auto x0 = transform_points(start_inverses[b].unsqueeze(0), xp.unsqueeze(1));  // [n, S, 3]
    const auto target = xp.unsqueeze(1).expand({n, I, 3}).reshape({-1, 3});
    if (I < S) {
      // Automatic starts: the I bones with the largest weight at their own rigid start.
      const auto w = field_->weights(x0).to(x0.dtype());  // [n, S, J]; all bones are candidates
      const auto own = w.diagonal(0, 1, 2);                // [n, S]
      const auto order = std::get<1>(own.nan_to_num(-1).topk(I, 1));
      x0 = x0.gather(1, order.unsqueeze(-1).expand({n, I, 3}));
    }
    auto x = x0.reshape({-1, 3}).clone();
    // Exact initial Jacobians (eq. 7); singular ones fall back to the identity.
    auto [jinv, info] = torch::linalg_inv_ex(spatial_jacobian(b, x));
    jinv.index_put_({info != 0}, torch::eye(3, x.options()));
    auto g = deform_prepared(b, x) - target;
    const int64_t P = x.size(0);
    auto active = torch::ones({P}, x.options().dtype(torch::kBool));
    auto converged = torch::zeros({P}, active.options());
    auto iterations = torch::zeros({P}, x.options().dtype(torch::kInt32));
    for (int k = 0;; ++k) {
      const auto norm_sq = g.square().sum(-1);
      converged = converged | (active & (norm_sq < options_.converge_sq));
      active = active & (norm_sq <= options_.diverge_sq) & (norm_sq >= options_.converge_sq);
      if (k == options_.max_iterations || !active.any().item<bool>()) break;
      const auto idx = active.nonzero().squeeze(1);
      const auto ja = jinv.index_select(0, idx), ga = g.index_select(0, idx);
      const auto dx = -torch::matmul(ja, ga.unsqueeze(-1)).squeeze(-1);
      const auto xa = x.index_select(0, idx) + dx;
      const auto gn = deform_prepared(b, xa) - target.index_select(0, idx);
      // Good Broyden update of J^-1 with SNARF's +-1e-6 on the denominator.
      const auto dg = gn - ga;
      const auto u = torch::matmul(ja, dg.unsqueeze(-1)).squeeze(-1);
      const auto v = torch::matmul(dx.unsqueeze(1), ja).squeeze(1);
      auto denom = (dx * u).sum(-1, true);
      denom = denom + torch::where(denom >= 0, torch::full_like(denom, 1e-6), torch::full_like(denom, -1e-6));
      const auto jn = ja + ((dx - u) / denom).unsqueeze(-1) * v.unsqueeze(1);
      x.index_copy_(0, idx, xa);
      g.index_copy_(0, idx, gn);
      jinv.index_copy_(0, idx, jn);
      iterations.index_add_(0, idx, torch::ones_like(idx, iterations.options()));
    }
    out.x[b] = x.reshape({n, I, 3});
    out.valid[b] = converged.reshape({n, I});
    out.iterations[b] = iterations.reshape({n, I});
    if (need_inverse_jacobian) out.inverse_jacobian[b] = jinv.reshape({n, I, 3, 3});
  }
  return out;
}

}  // namespace fskin
