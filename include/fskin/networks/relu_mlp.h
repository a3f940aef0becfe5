#pragma once
// The plain MLP of hash-grid fields (instant-ngp, tiny-cuda-nn's
// "FullyFusedMLP" / "CutlassMLP"): Linear + ReLU hidden layers, a linear
// output, LibTorch's default initialisation. A torch::nn::Sequential whose
// linear layers are its entries 0, 2, 4, ... (the parameter names checkpoints
// hold). The IDR-style networks of the skinning and occupancy fields are
// networks/mlp.h.
#include <torch/torch.h>

#include <cstdint>

namespace fskin {

struct ReluMlpOptions {
  int64_t input_dim = 32;
  int64_t output_dim = 4;
  int64_t hidden_dim = 64;
  int64_t hidden_layers = 2;  // >= 1
};

torch::nn::Sequential relu_mlp(const ReluMlpOptions& options);

}  // namespace fskin
