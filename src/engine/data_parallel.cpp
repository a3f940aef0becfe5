#include "fskin/engine/data_parallel.h"

#include <torch/torch.h>
#ifdef FSKIN_WITH_GLOO
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#endif

#include <cstdlib>

#include "fskin/core/error.h"

namespace fskin {

namespace {

// An integer environment variable within [lo, hi], or `fallback` when unset.
int integer_variable(const char* name, int fallback, int lo, int hi, bool required) {
  const char* text = std::getenv(name);
  if (text == nullptr || *text == '\0') {
    FSKIN_CHECK(!required, "{} is not set (WORLD_SIZE > 1: launch the ranks as torchrun does)", name);
    return fallback;
  }
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  FSKIN_CHECK(*end == '\0' && value >= lo && value <= hi, "{}={}: must be an integer in [{}, {}]", name, text, lo, hi);
  return static_cast<int>(value);
}

}  // namespace

LaunchEnvironment LaunchEnvironment::from_environment() {
  LaunchEnvironment e;
  e.world_size = integer_variable("WORLD_SIZE", 1, 1, 65536, false);
  const bool required = e.world_size > 1;
  e.rank = integer_variable("RANK", 0, 0, e.world_size - 1, required);
  e.local_rank = integer_variable("LOCAL_RANK", 0, 0, e.world_size - 1, false);
  e.master_port = integer_variable("MASTER_PORT", 29500, 1, 65535, required);
  if (const char* addr = std::getenv("MASTER_ADDR"); addr != nullptr && *addr != '\0') e.master_addr = addr;
  else FSKIN_CHECK(!required, "MASTER_ADDR is not set (WORLD_SIZE > 1: launch the ranks as torchrun does)");
  return e;
}

#ifdef FSKIN_WITH_GLOO

struct DataParallel::Group {
  c10::intrusive_ptr<c10d::Store> store;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> group;
  std::string where;  // MASTER_ADDR:MASTER_PORT, for messages
};

DataParallel::DataParallel(const LaunchEnvironment& environment, std::chrono::milliseconds timeout)
    : group_(std::make_unique<Group>()), rank_(environment.rank), world_size_(environment.world_size) {
  group_->where = environment.master_addr + ":" + std::to_string(environment.master_port);
  try {
    c10d::TCPStoreOptions store_options;
    store_options.port = static_cast<std::uint16_t>(environment.master_port);
    store_options.isServer = environment.rank == 0;
    store_options.numWorkers = static_cast<size_t>(environment.world_size);
    store_options.waitWorkers = true;
    store_options.timeout = timeout;
    group_->store = c10::make_intrusive<c10d::TCPStore>(environment.master_addr, store_options);
    auto options = c10d::ProcessGroupGloo::Options::create(timeout);
    options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname(environment.master_addr));
    group_->group =
        c10::make_intrusive<c10d::ProcessGroupGloo>(group_->store, environment.rank, environment.world_size, options);
  } catch (const std::exception& e) {
    fail("rank {} of {}: cannot join the other ranks at {} (MASTER_ADDR:MASTER_PORT): {}", environment.rank,
         environment.world_size, group_->where, e.what());
  }
}

DataParallel::~DataParallel() = default;

std::unique_ptr<DataParallel> join_launch_group() {
  const auto environment = LaunchEnvironment::from_environment();
  if (!environment.distributed()) return nullptr;
  const int seconds = integer_variable("FSKIN_RANK_TIMEOUT_S", 1800, 1, 7 * 24 * 3600, false);
  return std::make_unique<DataParallel>(environment, std::chrono::milliseconds(1000LL * seconds));
}

void DataParallel::average(const std::vector<torch::Tensor>& tensors) {
  std::vector<torch::Tensor> flat;
  for (const auto& t : tensors) {
    // Gloo reduces host memory: the buffer is on the CPU whatever the device.
    if (t.defined()) flat.push_back(t.detach().reshape({-1}).to(torch::kCPU, torch::kFloat64));
  }
  if (flat.empty()) return;
  std::vector<torch::Tensor> buffer = {torch::cat(flat)};
  try {
    group_->group->allreduce(buffer)->wait();
  } catch (const std::exception& e) {
    fail("rank {} of {}: another rank stopped answering (a gradient all-reduce failed): {}", rank_, world_size_,
         e.what());
  }
  buffer[0].div_(world_size_);
  int64_t offset = 0;
  torch::NoGradGuard no_grad;
  for (const auto& t : tensors) {
    if (!t.defined()) continue;
    const int64_t n = t.numel();
    t.copy_(buffer[0].slice(0, offset, offset + n).view(t.sizes()));
    offset += n;
  }
}

void DataParallel::broadcast_from_rank0(const std::vector<torch::Tensor>& tensors) {
  torch::NoGradGuard no_grad;
  for (const auto& t : tensors) {
    if (!t.defined()) continue;
    std::vector<torch::Tensor> buffer = {t.detach().to(torch::kCPU).contiguous().clone()};
    try {
      group_->group->broadcast(buffer)->wait();
    } catch (const std::exception& e) {
      fail("rank {} of {}: another rank stopped answering (a broadcast failed): {}", rank_, world_size_, e.what());
    }
    t.copy_(buffer[0]);
  }
}

void DataParallel::barrier() {
  try {
    group_->group->barrier()->wait();
  } catch (const std::exception& e) {
    fail("rank {} of {}: another rank stopped answering (a barrier failed): {}", rank_, world_size_, e.what());
  }
}

#else  // built without Gloo: one process only

struct DataParallel::Group {};

DataParallel::DataParallel(const LaunchEnvironment& environment, std::chrono::milliseconds)
    : rank_(environment.rank), world_size_(environment.world_size) {
  fail("WORLD_SIZE={}: this fskin was built without torch.distributed's Gloo backend (install libgloo-dev and "
       "build again) and trains as one process only",
       environment.world_size);
}
DataParallel::~DataParallel() = default;
void DataParallel::average(const std::vector<torch::Tensor>&) {}
void DataParallel::broadcast_from_rank0(const std::vector<torch::Tensor>&) {}
void DataParallel::barrier() {}

std::unique_ptr<DataParallel> join_launch_group() {
  const auto environment = LaunchEnvironment::from_environment();
  if (!environment.distributed()) return nullptr;
  return std::make_unique<DataParallel>(environment, std::chrono::milliseconds(0));
}

#endif

}  // namespace fskin
