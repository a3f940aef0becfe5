#include "fskin/core/device.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/util/stopwatch.h"

namespace fskin {
namespace {

std::string error_of(const std::string& name) {
  try {
    parse_device(name, "--device");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ParseDevice, NamesTheCpuAndRejectsOtherNamesWithTheFlag) {
  EXPECT_TRUE(parse_device("cpu").is_cpu());
  for (const std::string bad : {"", "gpu", "CUDA", "cuda:", "cuda:x", "cuda0", "cuda:-1", "cuda:1234", "cpu:0"}) {
    const auto message = error_of(bad);
    EXPECT_NE(message.find("--device " + bad + ": expected cpu, cuda or cuda:N"), std::string::npos)
        << "'" << bad << "' -> " << message;
  }
}

TEST(ParseDevice, CudaIsAGpuOrSaysWhyNot) {
  for (const std::string name : {"cuda", "cuda:0"}) {
    if (built_with_cuda() && torch::cuda::is_available()) {
      const auto device = parse_device(name);
      EXPECT_TRUE(device.is_cuda());
      EXPECT_EQ(device.index(), 0);
      continue;
    }
    const auto message = error_of(name);
    EXPECT_NE(message.find(built_with_cuda() ? "no CUDA device is visible" : "built without CUDA kernels"),
              std::string::npos)
        << message;
  }
  if (built_with_cuda() && torch::cuda::is_available()) {
    const auto count = torch::cuda::device_count();
    EXPECT_NE(error_of("cuda:" + std::to_string(count)).find("CUDA device(s) are visible"), std::string::npos);
  }
}

TEST(ModuleDevice, IsTheDeviceOfTheFirstTensorOrTheCpu) {
  torch::nn::Module empty;
  EXPECT_TRUE(module_device(empty).is_cpu());
  torch::nn::Linear linear(2, 3);
  EXPECT_TRUE(module_device(*linear).is_cpu());
  if (built_with_cuda() && torch::cuda::is_available()) {
    linear->to(torch::kCUDA);
    EXPECT_TRUE(module_device(*linear).is_cuda());
  }
}

TEST(Stopwatch, WaitsForTheGpuOnlyWhenCudaTimingIsOn) {
  EXPECT_FALSE(cuda_timing());  // the default: no host synchronisation per stage
  set_cuda_timing(true);
  EXPECT_TRUE(cuda_timing());
  Stopwatch watch(/*cuda=*/built_with_cuda() && torch::cuda::is_available());
  EXPECT_GE(watch.elapsed(), 0.0);
  set_cuda_timing(false);
  EXPECT_FALSE(cuda_timing());
}

}  // namespace
}  // namespace fskin
