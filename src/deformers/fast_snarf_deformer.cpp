#include "fskin/deformers/fast_snarf_deformer.h"

#include "fskin/core/error.h"
#include "fskin/ops/broyden_search.h"
#include "fskin/ops/grid_forward_skinning.h"

namespace fskin {

FastSnarfDeformer::FastSnarfDeformer(std::shared_ptr<GridSkinningField> field, DeformerOptions options)
    : Deformer(std::move(options)), field_(std::move(field)) {
  FSKIN_CHECK(field_ != nullptr, "FastSnarfDeformer: no skinning field");
}

void FastSnarfDeformer::prepare(const torch::Tensor& bones) {
  // T_v = sum_j w_vj B_j for every voxel (eq. 15): one [V, J] x [J, 12] product per frame.
  const auto grid = field_->grid_weights();  // [D, H, W, J]
  start_weights_ = grid.detach();
  const auto w = grid.to(bones.dtype());
  const int64_t B = bones.size(0), J = bones.size(1);
  const auto top = bones.narrow(2, 0, 3).reshape({B, 1, J, 12});
  const auto& s = field_->box().shape;
  transform_grid_ = torch::matmul(w.reshape({1, -1, J}), top.squeeze(1)).reshape({B, s.depth, s.height, s.width, 12});
}

Deformer::SearchResult FastSnarfDeformer::search(const torch::Tensor& x_posed, const torch::Tensor& start_inverses,
                                                 bool need_inverse_jacobian) {
  BroydenSearchOptions o = search_options();
  o.return_inverse_jacobian = need_inverse_jacobian;
  if (options_.start_bones.mode == StartBones::Mode::Automatic) {
    o.num_starts = options_.start_bones.slots(field_->num_bones());
  }
  torch::Tensor start_weights;
  // All bones are candidates, ranked on the weights prepare() read.
  if (o.num_starts >= 0) start_weights = start_weights_.defined() ? start_weights_ : field_->grid_weights().detach();
  auto r = broyden_search(transform_grid_.detach(), field_->box(), x_posed, start_inverses, o, start_weights);
  return {r.x_canonical, r.valid, r.iterations, r.inverse_jacobian};
}

torch::Tensor FastSnarfDeformer::deform_prepared(int64_t b, const torch::Tensor& x) {
  if (!torch::GradMode::is_enabled() || !(x.requires_grad() || transform_grid_.requires_grad())) {
    // No gradient wanted (evaluation, meshing, re-posing): the fused kernel.
    const auto frame = transform_grid_.narrow(0, b, 1);
    return grid_forward_skinning(frame, field_->box(), x.to(frame.dtype()).unsqueeze(0)).squeeze(0).to(x.dtype());
  }
  // Same trilinear interpolation as the kernels (eq. 14), differentiable.
  const auto t = sample_voxels(transform_grid_[b], field_->box(), x).reshape({-1, 3, 4});
  return torch::matmul(t.narrow(2, 0, 3), x.unsqueeze(-1)).squeeze(-1) + t.select(2, 3);
}

}  // namespace fskin
