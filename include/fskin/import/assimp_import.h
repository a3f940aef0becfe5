#pragma once
// Rigged characters from FBX, Collada (.dae) and the other formats Debian's
// assimp reads (imported_character.h says what comes out).
//
// - Joints: the bones that carry weights and every node between them and
//   their lowest common ancestor (so a skeleton whose hips carry no weight
//   still has one root); a node that is not a bone gets its rest transform
//   as bind matrix.
// - Units and axes: assimp's Collada reader applies <unit> and <up_axis>; for
//   FBX the file's UnitScaleFactor (centimetres per unit) and axis system
//   (UpAxis, FrontAxis, CoordAxis and their signs) are applied here, to
//   metres, +Y up, front +Z. Both are reported in the notes.
// - Clips: every animation, sampled at the union of its key times (linear
//   for positions and scales, slerp for rotations, clamped at the ends), in
//   seconds from the animation's ticks per second (25 when the file gives
//   none, assimp's convention).
#include "fskin/import/imported_character.h"

namespace fskin {

ImportedCharacter import_with_assimp(const std::string& path, const ImportOptions& options = {});

}  // namespace fskin
