#include "fskin/fields/mlp_skinning_field.h"

#include "fskin/core/error.h"

namespace fskin {

MlpSkinningField::MlpSkinningField(const MlpSkinningFieldOptions& options) : options_(options) {
  FSKIN_CHECK(options.num_bones >= 1, "MlpSkinningField: num_bones = {} must be >= 1", options.num_bones);
  MlpOptions mlp;
  mlp.input_dim = 3;
  mlp.output_dim = options.num_bones;
  mlp.hidden_dim = options.hidden_dim;
  mlp.hidden_layers = options.hidden_layers;
  network_ = register_module("network", Mlp(mlp));
}

torch::Tensor MlpSkinningField::weights(const torch::Tensor& x_canonical) {
  const auto logits = network_->forward(options_.input.apply(x_canonical.to(network_->parameters()[0].dtype())));
  return torch::softmax(logits * options_.softmax_scale, -1);
}

}  // namespace fskin
