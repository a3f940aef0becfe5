#pragma once
// Small built-in characters as skinned rigs, for the import tests.
#include <torch/torch.h>

#include "fskin/body/character.h"
#include "fskin/body/quadruped.h"
#include "fskin/data/pose_generators.h"
#include "fskin/export/skinned_gltf.h"

namespace fskin::testing {

inline BodyModel small_model(bool quadruped) {
  if (quadruped) {
    QuadrupedOptions o;
    o.resolution = 64;
    return make_quadruped_model(o);
  }
  CharacterOptions o;
  o.resolution = 48;
  return make_character_model(o);
}

// The model's template, weights and skeleton, with `frames` training poses
// and random root translations as its animation.
inline SkinnedCharacter skinned(const BodyModel& model, int64_t frames) {
  SkinnedCharacter c{model.rig()};
  if (frames > 0) {
    c.animation = make_training_poses(model.data().joint_names, {1, frames, 5});
    c.animation.trans = torch::randn({frames, 3}) * 0.2;
  }
  c.fps = 24;
  return c;
}

// The dense weights a top-4 export keeps.
inline torch::Tensor top4_dense(const torch::Tensor& weights) {
  const auto [ids, values] = top_influences(weights);
  return torch::zeros_like(weights).scatter_add(1, ids, values);
}

}  // namespace fskin::testing
