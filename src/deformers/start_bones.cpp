#include "fskin/deformers/start_bones.h"

#include <numeric>

#include "fskin/core/error.h"

namespace fskin {

StartBones StartBones::subset(std::vector<int64_t> indices) {
  FSKIN_CHECK(!indices.empty(), "StartBones::subset: empty bone list");
  StartBones s;
  s.mode = Mode::Subset;
  s.indices = std::move(indices);
  return s;
}

StartBones StartBones::by_name(const Skeleton& skeleton, const std::vector<std::string>& names) {
  std::vector<int64_t> indices;
  for (const auto& name : names) indices.push_back(skeleton.index_of(name));
  return subset(std::move(indices));
}

StartBones StartBones::automatic(int64_t count) {
  FSKIN_CHECK(count >= 1, "StartBones::automatic: count = {} must be >= 1", count);
  StartBones s;
  s.mode = Mode::Automatic;
  s.count = count;
  return s;
}

const std::vector<std::string>& StartBones::smpl_training_names() {
  static const std::vector<std::string> names = {"pelvis",         "left_hip",       "right_hip",
                                                 "left_knee",      "right_knee",     "left_shoulder",
                                                 "right_shoulder", "left_elbow",     "right_elbow"};
  return names;
}

std::vector<int64_t> StartBones::candidates(int64_t num_bones) const {
  if (mode != Mode::Subset) {
    std::vector<int64_t> all(static_cast<size_t>(num_bones));
    std::iota(all.begin(), all.end(), 0);
    return all;
  }
  for (int64_t i : indices) {
    FSKIN_CHECK(i >= 0 && i < num_bones, "start bones: index {} out of range for {} bones", i, num_bones);
  }
  return indices;
}

int64_t StartBones::slots(int64_t num_bones) const {
  if (mode == Mode::Automatic) return std::min(count, num_bones);
  return static_cast<int64_t>(candidates(num_bones).size());
}

}  // namespace fskin
