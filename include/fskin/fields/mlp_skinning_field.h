#pragma once
// SNARF's skinning field: an MLP 3 -> 4 x 128 -> J, weights = softmax(20 * logits).
#include "fskin/fields/skinning_field.h"
#include "fskin/networks/input_normalization.h"
#include "fskin/networks/mlp.h"

namespace fskin {

struct MlpSkinningFieldOptions {
  int64_t num_bones = 24;
  int64_t hidden_dim = 128;
  int64_t hidden_layers = 4;
  double softmax_scale = 20.0;  // sharpens the softmax (reference value)
  InputNormalization input;     // canonical points -> network coordinates
};

class MlpSkinningField : public SkinningField {
 public:
  explicit MlpSkinningField(const MlpSkinningFieldOptions& options = {});
  int64_t num_bones() const override { return options_.num_bones; }
  torch::Tensor weights(const torch::Tensor& x_canonical) override;
  Mlp& network() { return network_; }

 private:
  MlpSkinningFieldOptions options_;
  Mlp network_{nullptr};
};

}  // namespace fskin
