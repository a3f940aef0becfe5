#pragma once
// fskin's built-in procedural quadruped: a dog-sized animal generated from a
// seed, so that training, tests and benchmarks cover a skeleton that is not a
// person's (Fast-SNARF sec. 6 learns a 33-joint quadruped).
//
// 33 joints: a root at the hips, a three-joint spine, a two-joint neck, the
// head, two-joint ears, four four-joint legs (scapula/thigh, upper leg, lower
// leg, paw) and a six-joint tail. The body is a smooth union of ellipsoids
// and tapered capsules meshed to one closed genus-0 surface (as the built-in
// humanoid, character.h) standing on y = 0, +Y up, facing +Z, left along +X
// (docs/conventions.md); the rest pose is the standing pose and is the
// canonical pose. Skinning weights are a softmax over per-bone capsules,
// smoothed over the mesh; the joint regressor reproduces the designed joints.
// No shape or pose blend shapes. Deterministic for given options.
#include <cstdint>
#include <string>
#include <vector>

#include "fskin/body/body_model.h"

namespace fskin {

struct QuadrupedOptions {
  uint64_t seed = 0;
  int resolution = 150;   // grid cells along the body's length (~30k faces)
  double length = 1.5;    // metres from the nose to the tail tip
  double variation = 0.05;  // the seed scales each proportion by 1 +- up to this

  // Throws fskin::Error naming the option that is out of range.
  void validate() const;
};

// The quadruped's joint names and parents (parents[j] < j).
const std::vector<std::string>& quadruped_joint_names();
const std::vector<int64_t>& quadruped_parents();
// Whether a skeleton is the built-in quadruped's (same names, same order).
bool is_builtin_quadruped(const std::vector<std::string>& joint_names);

BodyModelData make_quadruped(const QuadrupedOptions& options);
// The same, validated as a BodyModel (source "built-in quadruped").
BodyModel make_quadruped_model(const QuadrupedOptions& options);

}  // namespace fskin
