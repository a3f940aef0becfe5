#pragma once
// A kinematic tree of any number of joints. Joints are stored in topological
// order (parents[j] < j, parents[0] == -1), as in SMPL's kintree_table.
#include <torch/types.h>

#include <string>
#include <vector>

namespace fskin {

struct Skeleton {
  std::vector<std::string> joint_names;  // one per joint, unique
  std::vector<int64_t> parents;          // parents[0] == -1
  torch::Tensor rest_joints;             // [J, 3] joint positions in the rest pose (metres)

  int64_t num_joints() const { return static_cast<int64_t>(parents.size()); }

  // Index of the joint called `name`; throws fskin::Error naming `name` if absent.
  int64_t index_of(const std::string& name) const;
  // Index of `name`, or -1.
  int64_t find(const std::string& name) const;
  std::vector<std::vector<int64_t>> children() const;

  // Throws fskin::Error (prefixed with `context`, e.g. a file name) unless the
  // tree is valid: >= 1 joint, one root at index 0, parents[j] < j, names
  // unique and as many as joints, rest_joints [J, 3] and finite.
  void validate(const std::string& context) const;
};

}  // namespace fskin
