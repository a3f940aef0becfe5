#pragma once
// The rigged character of an image dataset and of an avatar run
// (canonical.npz): canonical mesh, skinning weights and skeleton.
#include <torch/types.h>

#include <cstdint>
#include <string>
#include <vector>

namespace fskin {

// The character of an image dataset (canonical.npz).
struct AvatarCharacter {
  torch::Tensor vertices;  // [V, 3] canonical
  torch::Tensor faces;     // [F, 3] int64
  torch::Tensor weights;   // [V, J]
  torch::Tensor joints;    // [J, 3] canonical
  std::vector<std::string> joint_names;
  std::vector<int64_t> parents;
  int64_t num_joints() const { return static_cast<int64_t>(parents.size()); }
  static AvatarCharacter load(const std::string& path);
  void save(const std::string& path) const;
};

}  // namespace fskin
