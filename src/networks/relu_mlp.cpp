#include "fskin/networks/relu_mlp.h"

#include "fskin/core/error.h"

namespace fskin {

torch::nn::Sequential relu_mlp(const ReluMlpOptions& options) {
  FSKIN_CHECK(options.input_dim >= 1 && options.output_dim >= 1 && options.hidden_dim >= 1 &&
                  options.hidden_layers >= 1,
              "relu_mlp: widths and the number of hidden layers must be >= 1");
  torch::nn::Sequential mlp;
  int64_t width = options.input_dim;
  for (int64_t l = 0; l < options.hidden_layers; ++l) {
    mlp->push_back(torch::nn::Linear(width, options.hidden_dim));
    mlp->push_back(torch::nn::ReLU());
    width = options.hidden_dim;
  }
  mlp->push_back(torch::nn::Linear(width, options.output_dim));
  return mlp;
}

}  // namespace fskin
