#pragma once
// Picking named clips and frame ranges out of a clips file (the pose file
// `fskin import --clips` and `fskin character --clips` write: clips back to
// back with clip_names / clip_starts) into training and test pose files
// (`fskin poses select`).
//
// A selection is a comma-separated list of items, each a clip name, or a clip
// name and an inclusive range of its frames, counted from 0 within the clip:
//   "walk,idle"        every frame of walk, then every frame of idle
//   "walk:0-29,run"    walk's frames 0..29, then all of run
//   "walk:30-"         walk from frame 30 to its end
#include <cstdint>
#include <string>
#include <vector>

#include "fskin/data/pose_set.h"

namespace fskin {

struct ClipRange {
  std::string clip;
  int64_t first = 0;
  int64_t last = -1;  // inclusive; -1: the clip's last frame
};

// Parses a selection (throws fskin::Error quoting the item that is malformed).
std::vector<ClipRange> parse_clip_selection(const std::string& selection);

// The indices into clips.poses that the ranges pick, in the order given.
// Throws fskin::Error naming `source` for a file without clip names, a clip it
// does not have (listing the ones it has with their frame counts), or frames
// outside a clip.
std::vector<int64_t> selected_frames(const PoseSet& clips, const std::vector<ClipRange>& ranges,
                                     const std::string& source);

// The selected poses (with their translations), one clip per range, named
// "walk" for a whole clip and "walk:0-29" for part of one.
PoseSet select_clips(const PoseSet& clips, const std::vector<ClipRange>& ranges, const std::string& source);

}  // namespace fskin
