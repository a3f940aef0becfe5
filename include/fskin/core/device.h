#pragma once
// Where a command computes: `--device cpu|cuda|cuda:N`, and which device a
// module's tensors are on. The library's entry points (training, evaluation,
// meshing, re-posing) move their inputs to the model's device and their
// results back to the host, so a caller only chooses where the model lives.
#include <torch/torch.h>

#include <string>

namespace fskin {

// "cpu", "cuda" or "cuda:N" -> the device; throws fskin::Error naming `what`
// (the flag) when the name is malformed, when this build has no CUDA kernels
// (a LibTorch without CUDA) or when no such GPU is visible.
torch::Device parse_device(const std::string& name, const std::string& what = "--device");

// Whether the library was built with its CUDA kernels (FSKIN_WITH_CUDA).
bool built_with_cuda();

// The device of the module's first parameter or buffer; the CPU for a module
// without tensors.
torch::Device module_device(const torch::nn::Module& module);

}  // namespace fskin
