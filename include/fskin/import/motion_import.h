#pragma once
// Motion for a model from capture files (`fskin poses import`):
// - BVH, retargeted by joint name (with an optional name map). BVH joint
//   frames are world-aligned at the zero pose, as fskin's are at the rest
//   pose, so each model joint takes the global orientation of its BVH joint
//   and its local rotation follows from its parent's; BVH joints between two
//   mapped ones are folded into the child, model joints without a BVH joint
//   keep their parent's orientation. The root translation is scaled from the
//   BVH skeleton's size to the model's. It assumes both rest poses have the
//   same limb directions (T-pose to T-pose) and +Y up; what differs is
//   reported, not corrected.
// - AMASS / SMPL-style .npz (poses [T, 3J'], trans [T, 3], optional
//   mocap_framerate): joint j of the file drives joint j of the model; an
//   SMPL-H or SMPL-X file (52 / 55 joints) on a 24-joint SMPL model keeps the
//   22 body joints and leaves the hands at rest.
#include <map>
#include <string>
#include <vector>

#include "fskin/data/pose_set.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

struct ImportedMotion {
  PoseSet poses;  // for the model's skeleton
  double fps = 30;
  std::vector<std::string> notes;
};

// name_map: BVH joint name -> model joint name (joints not in it match by name).
ImportedMotion import_bvh(const std::string& path, const Skeleton& model,
                          const std::map<std::string, std::string>& name_map = {});
ImportedMotion import_amass(const std::string& path, const Skeleton& model);

// "bvh_name=model_name" lines (blank lines and # comments ignored).
std::map<std::string, std::string> read_name_map(const std::string& path);

}  // namespace fskin
