#pragma once
// A rigged character read from a file (`fskin import`): its skinned mesh,
// skeleton and animation clips as an SMPL-format body model and pose sets
// that the rest of fskin trains on. Every reader (gltf_import.h for glTF 2.0,
// assimp_import.h for FBX, Collada and the other formats assimp reads)
// produces the same thing the same way:
//
// - Skeleton: the joints that skin the mesh, parents from the node tree,
//   reordered so parents come first; rest joints from the inverse bind
//   matrices. Exactly one root is required.
// - Mesh: the skinned triangles of every part, merged, vertices welded by
//   position (files split them at UV and normal seams) so a closed surface
//   comes out closed; parts that are not closed are dropped and reported
//   (ImportOptions::keep_open_parts keeps them); none closed is an error.
//   In metres with +Y up (the reader converts what the file declares).
// - Weights: renormalised per vertex.
// - Clips: each animation sampled at its keyframe times, the skinning
//   matrices turned into local rotations relative to the rest pose, a root
//   translation and, for clips that move non-root joints off their rest
//   offsets, joint translations (pose_from_bones.h). Joint transforms are
//   rigid: animated scales are dropped and reported.
#include <string>
#include <vector>

#include "fskin/body/body_model.h"
#include "fskin/data/pose_set.h"

namespace fskin {

struct ImportedClip {
  std::string name;
  PoseSet poses;  // [T, J, 3] local rotations, trans [T, 3], joint_translations or none, joint names
  double fps = 30;             // from the keyframe spacing (1 / median step), for playback
  double max_joint_drift = 0;  // metres, without joint translations (pose_from_bones.h)
};

struct ImportedCharacter {
  BodyModelData model;  // v_template, faces, weights, rest_joints, parents, joint_names
  std::vector<ImportedClip> clips;
  std::vector<std::string> notes;  // what was merged, welded, dropped, converted or approximated
};

struct ImportOptions {
  // Keep parts that are not closed surfaces (for looking at a rig or taking
  // its clips; training needs closed surfaces to tell inside from outside).
  bool keep_open_parts = false;
  // assimp's readers can crash, loop or allocate without end on hostile
  // files: assimp first reads the file in a child process limited to this
  // wall-clock time and this much memory beyond the caller's, and the file
  // is refused (naming it) if the child crashes or runs out of either.
  double assimp_seconds = 120;
  int64_t assimp_memory_mib = 4096;
};

// By extension: .glb / .gltf through import_gltf, anything else through
// import_with_assimp. Throws fskin::Error naming the file and the part for
// what cannot be used: no skinned mesh, no closed part, more than one root,
// vertices without weights, a file the reader cannot parse.
ImportedCharacter import_character(const std::string& path, const ImportOptions& options = {});

// All clips back to back in one pose set, with their names and starts.
PoseSet concatenate_clips(const std::vector<ImportedClip>& clips);

}  // namespace fskin
