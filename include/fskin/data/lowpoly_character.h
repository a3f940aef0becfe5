#pragma once
// fskin's game-style test characters: built like the low-poly assets people
// download, not like fskin's smooth procedural bodies (character.h,
// quadruped.h), so that accuracy is measured on what real files bring:
//   - a few hundred faceted vertices: separate closed parts (torso, limbs,
//     head, palms, fingers, paws) lofted through a few polygonal rings, sharp
//     creases, pointed muzzles and ears, overlapping where they join;
//   - thin flat parts: ears (about 0.7-0.9 % of the character's size thick),
//     a cape or a flat tail (about 1.1-1.3 %), separate fingers 1.8 cm wide
//     with 0.8 cm gaps at 1.8 m;
//   - painted weights: one bone per ring, a 50/50 ring at some bends, hard
//     boundaries elsewhere, nothing smoothed; a weightless root joint on the
//     ground above which the hips hang, and leaf bones with no vertices
//     (head top, finger, toe, nose, ear and tail ends);
//   - joint names of game rigs (Mixamo-style for the humanoid, Blender-style
//     for the animal), no SMPL names, so nothing SMPL-only switches on;
//   - motion as named animation clips (the clips file `fskin import --clips`
//     writes), not random rotations.
// The humanoid stands 1.8 m tall (+Y up) facing +Z in a T-pose; the animal, a
// fox, is 0.9 m from nose to tail tip, faces +X and stands on y = 0.
// Deterministic for given options.
#include <cstdint>
#include <string>
#include <vector>

#include "fskin/body/body_model.h"
#include "fskin/data/pose_set.h"

namespace fskin {

enum class LowPolyKind { Humanoid, Animal };

struct LowPolyOptions {
  LowPolyKind kind = LowPolyKind::Humanoid;
  uint64_t seed = 0;
  // Height (humanoid) or nose-to-tail length (animal) in the model's units;
  // 0: 1.8 (humanoid) or 0.9 (animal).
  double size = 0;
  double variation = 0.05;  // the seed scales each proportion by 1 +- up to this

  // Throws fskin::Error naming the option that is out of range.
  void validate() const;
};

struct LowPolyCharacter {
  BodyModelData model;  // v_template, faces, weights, rest_joints, parents, joint_names
  // Named clips back to back (clip_names / clip_starts), 30 frames per second.
  // Humanoid: idle, walk, wave, run; animal: idle, walk, run. The run is the
  // out-of-distribution clip of the benchmarks: its amplitudes exceed the others'.
  PoseSet clips;
};

LowPolyCharacter make_lowpoly_character(const LowPolyOptions& options);
// The model of make_lowpoly_character, validated as a BodyModel.
BodyModel make_lowpoly_model(const LowPolyOptions& options);

// "lowpoly-humanoid" / "lowpoly-animal" <-> LowPolyKind (throws fskin::Error
// for other names).
LowPolyKind parse_lowpoly_kind(const std::string& name);
std::string lowpoly_kind_name(LowPolyKind kind);

}  // namespace fskin
