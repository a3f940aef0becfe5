#pragma once
// A skinned character as a glTF 2.0 asset that engines, three.js and Blender
// play as a normal rigged character: one mesh with JOINTS_0 / WEIGHTS_0 (the
// four largest influences per vertex, renormalised: what every engine and
// three.js read), or more sets JOINTS_n / WEIGHTS_n for more influences
// (glTF allows them; Blender reads them), a skin whose joints are nodes of
// the kinematic tree, and optionally a pose set as an animation. Vertex
// colours (Mesh::colors, 8-bit sRGB) become COLOR_0 (linear, as glTF wants).
//
// Joint nodes carry fskin's joint frames (docs/conventions.md): at rest a
// joint's translation is rest_j - rest_parent and its rotation the identity,
// and its inverse bind matrix translates by -rest_j, so the skinning matrix
// of joint j is exactly forward_kinematics' bone transform B_j. The
// animation has one rotation channel per joint (the pose's local rotations)
// and a translation channel for the root (rest_0 + trans) and, when the pose
// set has joint translations, for every other joint (rest_j - rest_parent +
// its translation), LINEAR, one keyframe per pose at t = i / fps.
#include <torch/types.h>

#include <string>
#include <utility>

#include "fskin/data/pose_set.h"
#include "fskin/geometry/mesh.h"
#include "fskin/skeleton/rigged_mesh.h"

namespace fskin {

// A rig (mesh, weights, skeleton in the bind pose) and what the file adds.
struct SkinnedCharacter : RiggedMesh {
  PoseSet animation;      // optional (size() == 0: none); poses relative to the rest pose
  double fps = 30;
  std::string animation_name = "poses";
  // Influences per vertex: the largest weights, renormalised, in sets of
  // four; 0 keeps every joint's weight (the exact skinning, ceil(J / 4) sets).
  int64_t influences = 4;

  // Throws fskin::Error prefixed with `context` unless the rig is valid
  // (RiggedMesh::validate) and the animation, fps and influences fit it.
  void validate(const std::string& context) const;
};

// The animation a skinned asset of `skeleton` (joints in the bind pose) plays
// for bone transforms [T, J, 4, 4] (bind -> posed): local rotations, the root's
// translation, and per-joint translations only when the bones move joints off
// their bind offsets (skeleton/pose_from_bones.h).
PoseSet animation_from_bones(const Skeleton& skeleton, const torch::Tensor& bones);

// The `k` largest weights per vertex, renormalised: (joint indices [V, k]
// int64, weights [V, k] float).
std::pair<torch::Tensor, torch::Tensor> top_influences(const torch::Tensor& weights, int64_t k = 4);

// Writes `character` to path (.glb or .gltf) atomically.
void write_skinned_gltf(const std::string& path, const SkinnedCharacter& character);

}  // namespace fskin
