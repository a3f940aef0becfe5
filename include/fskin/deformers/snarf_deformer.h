#pragma once
// SNARF (Alg. 1 variant 1): the skinning field (usually an MLP) is evaluated at
// every Broyden iteration, batched over all (point, start) lanes, between the
// steps of the solver the fused Fast-SNARF kernels run (ops/broyden_lanes.h);
// exact initial Jacobians (eq. 7) and exact implicit gradients (eq. 14) by
// default. The accuracy reference; slow.
#include "fskin/deformers/deformer.h"

namespace fskin {

class SnarfDeformer : public Deformer {
 public:
  SnarfDeformer(std::shared_ptr<SkinningField> field, DeformerOptions options = DeformerOptions::snarf());
  SkinningField& field() override { return *field_; }

 protected:
  void prepare(const torch::Tensor& bones) override { bones_ = bones; }
  SearchResult search(const torch::Tensor& x_posed, const torch::Tensor& start_inverses,
                      bool need_inverse_jacobian) override;
  torch::Tensor deform_prepared(int64_t b, const torch::Tensor& x) override;
  void release() override { bones_ = torch::Tensor(); }

 private:
  std::shared_ptr<SkinningField> field_;
  torch::Tensor bones_;  // [B, J, 4, 4] of the pose being searched
};

}  // namespace fskin
