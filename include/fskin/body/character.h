#pragma once
// fskin's built-in procedural character: an SMPL-format humanoid generated from
// a seed, so that everything runs without third-party body models.
//
// The body is the smooth union (smooth minimum) of ellipsoids and tapered
// capsules, meshed with iso_surface and cleaned to exactly one closed manifold
// component. It is rigged to SMPL's 24-joint tree (names, parents and order of
// SMPL) in a T-pose: +Y up, +Z forward, arms horizontal along +-X, feet on y = 0
// (docs/conventions.md). It comes with
//   - J_regressor: convex (maximum-entropy) weights over a ring of vertices
//     around each joint that regress the designed joint; the regressed joints
//     are the rest joints of everything below, and the plain and clothed
//     variants share them,
//   - skinning weights: a softmax over the distances to per-bone capsules,
//     smoothed over the mesh (>= 0, rows sum to 1),
//   - posedirs: bulges along the normal near elbows, knees, shoulders, hips and
//     the spine, proportional to 1 - cos(theta) = -trace(R_j - I) / 2,
//   - shapedirs: two directions, height (+3 % per unit) and girth (+1 cm along
//     the normal per unit).
// The clothed variant adds a flared skirt (a solid elliptic cone from the waist
// to above the knees, part of the same closed surface) whose weights blend
// pelvis, hips and knees by height: LBS then deforms it like loose clothing.
// Its hem also flares outward as either hip bends (6 cm at 1.7 m per unit of
// 1 - cos(theta), both sides for either hip): a pose-dependent deformation
// that no pose-free skinning weights reproduce, which is what INS and
// pose-conditioned SNARF are meant to learn and SNARF-NC cannot.
// Deterministic: the same options give bit-identical tensors, with any number
// of threads.
#include <cstdint>
#include <string>
#include <vector>

#include "fskin/body/body_model.h"
#include "fskin/body/smpl_skeleton.h"

namespace fskin {

struct CharacterOptions {
  uint64_t seed = 0;     // varies the proportions slightly (see `variation`)
  bool clothed = false;  // add the skirt
  int resolution = 110;  // grid cells along the body's height (~20k faces)
  double height = 1.7;   // metres, top of the head above the soles
  // Proportions: multipliers of the default body, applied before the seed's variation.
  double girth = 1.0;  // thickness of limbs and torso
  double shoulder_width = 1.0;
  double hip_width = 1.0;
  double arm_length = 1.0;
  double leg_length = 1.0;
  double head_size = 1.0;
  double variation = 0.05;  // the seed scales each proportion by 1 +- up to this

  // Throws fskin::Error naming the option that is out of range.
  void validate() const;
};

BodyModelData make_character(const CharacterOptions& options);
// The same, validated as a BodyModel (source "built-in character").
BodyModel make_character_model(const CharacterOptions& options);

}  // namespace fskin
