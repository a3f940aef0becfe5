#include "fskin/core/device.h"

#include <torch/cuda.h>

#include "fskin/core/error.h"

namespace fskin {

bool built_with_cuda() {
#ifdef FSKIN_WITH_CUDA
  return true;
#else
  return false;
#endif
}

torch::Device parse_device(const std::string& name, const std::string& what) {
  if (name == "cpu") return torch::kCPU;
  const std::string prefix = "cuda";
  FSKIN_CHECK(name.compare(0, prefix.size(), prefix) == 0, "{} {}: expected cpu, cuda or cuda:N", what, name);
  int index = 0;
  if (name.size() > prefix.size()) {
    const std::string digits = name.substr(prefix.size() + 1);
    FSKIN_CHECK(name[prefix.size()] == ':' && !digits.empty() && digits.size() <= 3 &&
                    digits.find_first_not_of("0123456789") == std::string::npos,
                "{} {}: expected cpu, cuda or cuda:N", what, name);
    index = std::stoi(digits);
  }
  FSKIN_CHECK(built_with_cuda(),
              "{} {}: this fskin was built without CUDA kernels (its LibTorch has no CUDA); configure it against a "
              "CUDA LibTorch (README, 'Building against another LibTorch')",
              what, name);
  const auto count = static_cast<int>(torch::cuda::device_count());
  FSKIN_CHECK(count > 0, "{} {}: no CUDA device is visible (CUDA_VISIBLE_DEVICES, driver)", what, name);
  FSKIN_CHECK(index < count, "{} {}: only {} CUDA device(s) are visible", what, name, count);
  return {torch::kCUDA, static_cast<c10::DeviceIndex>(index)};
}

torch::Device module_device(const torch::nn::Module& module) {
  for (const auto& p : module.parameters()) return p.device();
  for (const auto& b : module.buffers()) return b.device();
  return torch::kCPU;
}

}  // namespace fskin
