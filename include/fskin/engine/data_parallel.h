#pragma once
// Data-parallel training on torch.distributed's c10d (Gloo on CPUs) as
// Debian's LibTorch ships it. Ranks are launched the way `torchrun` launches
// them: every process gets RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR and
// MASTER_PORT; rank 0 hosts the rendezvous store (c10d's TCPStore) on
// MASTER_ADDR:MASTER_PORT. In a step every rank computes the losses of its
// share of the step's batch (engine/trainable.h, Shard), and the gradients
// are averaged over the ranks before the optimiser steps, so N ranks take the
// step one process would take on the whole batch. Rank 0 alone writes the run.
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <torch/types.h>

namespace fskin {

// This process's place in a launch, from torchrun's environment variables.
struct LaunchEnvironment {
  int rank = 0, world_size = 1, local_rank = 0;
  std::string master_addr = "127.0.0.1";
  int master_port = 29500;
  bool distributed() const { return world_size > 1; }
  // Reads RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR, MASTER_PORT; unset
  // WORLD_SIZE means one process. Throws fskin::Error naming the variable when
  // one is malformed or missing while WORLD_SIZE > 1.
  static LaunchEnvironment from_environment();
};

class DataParallel {
 public:
  // Joins the other ranks (rank 0 hosts the store); throws fskin::Error naming
  // MASTER_ADDR:MASTER_PORT when they do not all arrive within `timeout`.
  // Collectives fail after `timeout` too (a rank that stopped answering).
  DataParallel(const LaunchEnvironment& environment, std::chrono::milliseconds timeout);
  ~DataParallel();
  DataParallel(const DataParallel&) = delete;
  DataParallel& operator=(const DataParallel&) = delete;

  int rank() const { return rank_; }
  int world_size() const { return world_size_; }

  // The mean over the ranks of each tensor, in place, in one all-reduce of a
  // flattened float64 buffer (undefined tensors are skipped). Throws
  // fskin::Error naming the rank when another rank is gone.
  void average(const std::vector<torch::Tensor>& tensors);
  // Rank 0's values of each tensor on every rank, in place.
  void broadcast_from_rank0(const std::vector<torch::Tensor>& tensors);
  void barrier();

 private:
  struct Group;
  std::unique_ptr<Group> group_;
  int rank_ = 0, world_size_ = 1;
};

// The data-parallel group this process was launched into (torchrun's
// variables), or null when it runs alone (WORLD_SIZE unset or 1). Collectives
// time out after FSKIN_RANK_TIMEOUT_S seconds (default 1800, torchrun's).
std::unique_ptr<DataParallel> join_launch_group();

}  // namespace fskin
