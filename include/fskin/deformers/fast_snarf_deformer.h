#pragma once
// Fast-SNARF (Alg. 1 variant 2): blended transforms precomputed per voxel
// (eq. 15), then one fused Broyden kernel per (point, start) (ops/broyden_search)
// and duplicate removal. Approximate gradient by default (eq. 17), exact
// selectable. With a DistilledSkinningField the grid is re-distilled from the
// MLP on every forward so training updates the MLP (sec. 4.2).
#include "fskin/deformers/deformer.h"

namespace fskin {

class FastSnarfDeformer : public Deformer {
 public:
  FastSnarfDeformer(std::shared_ptr<GridSkinningField> field,
                    DeformerOptions options = DeformerOptions::fast_snarf());
  SkinningField& field() override { return *field_; }

 protected:
  void prepare(const torch::Tensor& bones) override;
  SearchResult search(const torch::Tensor& x_posed, const torch::Tensor& start_inverses,
                      bool need_inverse_jacobian) override;
  torch::Tensor deform_prepared(int64_t b, const torch::Tensor& x) override;
  void release() override {
    transform_grid_ = torch::Tensor();
    start_weights_ = torch::Tensor();
  }

 private:
  std::shared_ptr<GridSkinningField> field_;
  torch::Tensor transform_grid_;  // [B, D, H, W, 12], with the graph when training
  // The grid's weights [D, H, W, J] as prepare() read them, without the graph:
  // what the automatic start bones rank (reading the field again would
  // evaluate a distilled field's MLP at every voxel a second time).
  torch::Tensor start_weights_;
};

}  // namespace fskin
