#pragma once
// Which bones seed the Broyden search (SNARF eq. 7: x0 = B_s^-1 x').
#include <cstdint>
#include <string>
#include <vector>

#include "fskin/skeleton/skeleton.h"

namespace fskin {

struct StartBones {
  enum class Mode { All, Subset, Automatic };
  Mode mode = Mode::All;
  std::vector<int64_t> indices;  // Subset: the bones, in slot order
  int64_t count = 0;             // Automatic: starts kept per point

  static StartBones all() { return {}; }
  static StartBones subset(std::vector<int64_t> indices);
  static StartBones by_name(const Skeleton& skeleton, const std::vector<std::string>& names);
  // Per point, the `count` bones s with the largest weight w_s(B_s^-1 x') at
  // their own rigid start, i.e. whose inverse lands in the region they drive.
  static StartBones automatic(int64_t count);
  // The papers' SMPL training list: pelvis, hips, knees, shoulders, elbows.
  static const std::vector<std::string>& smpl_training_names();

  // The candidate bones for a skeleton of J bones (throws fskin::Error if out of range).
  std::vector<int64_t> candidates(int64_t num_bones) const;
  // Candidates kept per point (I in [B, N, I]).
  int64_t slots(int64_t num_bones) const;
};

}  // namespace fskin
