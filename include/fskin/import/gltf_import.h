#pragma once
// Rigged characters from glTF 2.0 files (.glb / .gltf): the skinned mesh, its
// skeleton and every animation clip, as an SMPL-format body model and pose
// sets that the rest of fskin trains on (`fskin import`).
//
// - Skeleton: the joints of the skin used by the skinned mesh nodes (other
//   skins are dropped and reported), parents from the node tree, reordered so
//   parents come first; rest joints from the inverse bind matrices. Exactly
//   one root is required.
// - Mesh: every triangle primitive skinned with that skin, merged, vertices
//   welded by position (glTF splits them at UV and normal seams) so a closed
//   surface comes out closed; components that are not closed are dropped and
//   reported; none closed is an error. glTF is in metres with +Y up, so
//   nothing is converted.
// - Weights: JOINTS_0/WEIGHTS_0 (and _1), renormalised.
// - Clips: each animation sampled at its keyframe times (LINEAR and STEP as
//   specified; CUBICSPLINE at its keyframe values), the skinning matrices
//   turned into local rotations relative to the rest pose and a root
//   translation (pose_from_bones.h). fskin's poses are rotations per joint, so
//   a clip that also animates translations or scales of non-root joints is
//   reported with the largest joint drift this costs.
#include <string>
#include <vector>

#include "fskin/body/body_model.h"
#include "fskin/data/pose_set.h"

namespace fskin {

struct ImportedClip {
  std::string name;
  PoseSet poses;  // [T, J, 3] local rotations, trans [T, 3], the model's joint names
  double fps = 30;             // from the keyframe spacing (1 / median step), for playback
  double max_joint_drift = 0;  // metres (pose_from_bones.h)
};

struct ImportedCharacter {
  BodyModelData model;  // v_template, faces, weights, rest_joints, parents, joint_names
  std::vector<ImportedClip> clips;
  std::vector<std::string> notes;  // what was merged, welded, dropped or approximated
};

struct GltfImportOptions {
  // Keep parts that are not closed surfaces (for looking at a rig or taking
  // its clips; training needs closed surfaces to tell inside from outside).
  bool keep_open_parts = false;
};

// Throws fskin::Error naming the file and the part for what cannot be used:
// no skinned mesh, no closed part, more than one root, vertices without weights.
ImportedCharacter import_gltf(const std::string& path, const GltfImportOptions& options = {});

// All clips back to back in one pose set, with their names and starts.
PoseSet concatenate_clips(const std::vector<ImportedClip>& clips);

}  // namespace fskin
