#pragma once
// A ready-made deformation problem on fskin's built-in character, shared by
// the deformer benchmarks (CLI and Google Benchmark) and tests: canonical
// Da-pose, the model's weights diffused into a voxel grid (preset field), a
// natural or an extreme target pose, and query points sampled like the papers'
// evaluation (half uniform in 1.1x the posed bounding box, half near the surface).
#include <torch/torch.h>

#include <memory>

#include "fskin/body/body_model.h"
#include "fskin/fields/mlp_skinning_field.h"
#include "fskin/fields/voxel_skinning_field.h"

namespace fskin {

enum class ScenePose { Natural, Extreme };

struct CharacterScene {
  Skeleton skeleton;
  torch::Tensor canonical_vertices;  // [V, 3] Da-pose
  torch::Tensor posed_vertices;      // [V, 3] target pose
  torch::Tensor faces;               // [F, 3]
  std::shared_ptr<FrozenSkinningField> field;
  torch::Tensor bones;               // [1, J, 4, 4] canonical -> posed
};

// Axis-angle [J, 3] of the benchmark poses; joints found by SMPL name.
// Natural: a walking step with bent arms. Extreme: deep squat, arms crossed
// over the chest, twisted spine and raised leg (self-contact).
torch::Tensor scene_pose(const Skeleton& skeleton, ScenePose pose);

CharacterScene make_character_scene(const BodyModel& model, ScenePose pose, GridShape grid = {});

// n posed query points [1, n, 3]: half uniform in 1.1x the posed bounding
// box, half on the posed surface plus N(0, 0.01 m) noise.
torch::Tensor sample_query_points(const CharacterScene& scene, int64_t n, uint64_t seed);

// n points [1, n, 3] on the canonical surface plus N(0, noise) along each axis.
torch::Tensor sample_canonical_surface(const CharacterScene& scene, int64_t n, double noise, uint64_t seed);

// SNARF's MLP field (3 -> 4 x 128 -> J) fitted to the scene's preset weights
// by `steps` Adam steps, so the SNARF-MLP path has realistic weights to search.
std::shared_ptr<MlpSkinningField> fit_mlp_skinning_field(const CharacterScene& scene, int steps, uint64_t seed);

}  // namespace fskin
