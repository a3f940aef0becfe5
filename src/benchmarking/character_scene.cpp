#include "fskin/benchmarking/character_scene.h"

#include <ATen/CPUGeneratorImpl.h>

#include "fskin/core/error.h"
#include "fskin/fields/preset_skinning_field.h"
#include "fskin/skeleton/forward_kinematics.h"

namespace fskin {

namespace {

// Area-weighted random points on a triangle mesh [n, 3].
torch::Tensor sample_surface(const torch::Tensor& vertices, const torch::Tensor& faces, int64_t n,
                             torch::Generator& gen) {
  const auto tri = vertices.index_select(0, faces.reshape({-1})).reshape({-1, 3, 3});
  const auto area = torch::cross(tri.select(1, 1) - tri.select(1, 0), tri.select(1, 2) - tri.select(1, 0), -1).norm(2, -1);
  const auto face = torch::multinomial(area, n, /*replacement=*/true, gen);
  // Uniform barycentric coordinates: u = 1 - sqrt(r1), v = sqrt(r1) (1 - r2), w = sqrt(r1) r2.
  const auto r1 = torch::rand({n, 1}, gen).sqrt();
  const auto r2 = torch::rand({n, 1}, gen);
  const auto t = tri.index_select(0, face);
  return (1 - r1) * t.select(1, 0) + r1 * (1 - r2) * t.select(1, 1) + r1 * r2 * t.select(1, 2);
}

}  // namespace

torch::Tensor scene_pose(const Skeleton& skeleton, ScenePose pose) {
  auto aa = torch::zeros({skeleton.num_joints(), 3});
  auto set = [&](const char* joint, double x, double y, double z) {
    const auto j = skeleton.index_of(joint);
    aa[j][0] = x;
    aa[j][1] = y;
    aa[j][2] = z;
  };
  if (pose == ScenePose::Natural) {
    set("left_hip", -0.5, 0.0, 0.1);
    set("right_hip", 0.3, 0.0, -0.1);
    set("left_knee", 0.6, 0.0, 0.0);
    set("right_knee", 0.2, 0.0, 0.0);
    set("left_shoulder", 0.0, 0.2, -1.1);
    set("right_shoulder", 0.0, -0.2, 1.1);
    set("left_elbow", 0.0, -0.8, 0.0);
    set("right_elbow", 0.0, 0.8, 0.0);
    set("spine1", 0.1, 0.1, 0.0);
  } else {
    set("pelvis", 0.3, 0.4, 0.0);
    set("left_hip", -2.0, 0.0, 0.3);
    set("right_hip", -1.6, 0.0, -0.3);
    set("left_knee", 2.3, 0.0, 0.0);
    set("right_knee", 2.1, 0.0, 0.0);
    set("spine1", 0.4, 0.5, 0.0);
    set("spine2", 0.3, 0.4, 0.0);
    set("left_shoulder", 0.0, -1.2, -0.6);
    set("right_shoulder", 0.0, 1.2, 0.6);
    set("left_elbow", 0.0, -2.2, 0.0);
    set("right_elbow", 0.0, 2.2, 0.0);
    set("neck", 0.5, 0.0, 0.0);
  }
  return aa;
}

CharacterScene make_character_scene(const BodyModel& model, ScenePose pose, GridShape grid) {
  torch::NoGradGuard no_grad;
  CharacterScene s;
  s.skeleton = model.skeleton();
  s.faces = model.data().faces;
  const auto poses = torch::stack({da_pose(s.skeleton), scene_pose(s.skeleton, pose)});
  const auto posed = model.pose(poses);
  s.canonical_vertices = posed.vertices[0];
  s.posed_vertices = posed.vertices[1];
  // Deformers take canonical -> posed transforms (docs/conventions.md).
  s.bones = relative_bone_transforms(posed.bone_transforms.narrow(0, 1, 1), posed.bone_transforms.narrow(0, 0, 1));
  s.field = diffuse_weights_to_grid(s.canonical_vertices, model.data().weights,
                                    VoxelBox::around(s.canonical_vertices, grid));
  return s;
}

torch::Tensor sample_query_points(const CharacterScene& scene, int64_t n, uint64_t seed) {
  FSKIN_CHECK(n >= 0, "sample_query_points: n = {} must be >= 0", n);
  auto gen = at::detail::createCPUGenerator(seed);
  const auto v = scene.posed_vertices;
  const auto lo = std::get<0>(v.min(0)), hi = std::get<0>(v.max(0));
  const auto centre = (lo + hi) / 2, half = (hi - lo) / 2 * 1.1;
  const int64_t uniform = n / 2;
  const auto box = centre + (torch::rand({uniform, 3}, gen) * 2 - 1) * half;
  const auto near = sample_surface(v, scene.faces, n - uniform, gen) + torch::randn({n - uniform, 3}, gen) * 0.01;
  return torch::cat({box, near}).unsqueeze(0);
}

torch::Tensor sample_canonical_surface(const CharacterScene& scene, int64_t n, double noise, uint64_t seed) {
  auto gen = at::detail::createCPUGenerator(seed);
  const auto p = sample_surface(scene.canonical_vertices, scene.faces, n, gen);
  return (p + torch::randn({n, 3}, gen) * noise).unsqueeze(0);
}

std::shared_ptr<MlpSkinningField> fit_mlp_skinning_field(const CharacterScene& scene, int steps, uint64_t seed) {
  FSKIN_CHECK(steps >= 0, "fit_mlp_skinning_field: steps = {} must be >= 0", steps);
  torch::manual_seed(seed);
  MlpSkinningFieldOptions o;
  o.num_bones = scene.field->num_bones();
  auto mlp = std::make_shared<MlpSkinningField>(o);
  torch::optim::Adam adam(mlp->parameters(), torch::optim::AdamOptions(1e-3));
  const auto& box = scene.field->box();
  const auto centres = box.voxel_centres().reshape({-1, 3});
  for (int step = 0; step < steps; ++step) {
    // Voxel centres near the body plus surface points: where the search looks.
    const auto idx = torch::randint(centres.size(0), {2048}, torch::kInt64);
    const auto x = torch::cat({centres.index_select(0, idx), sample_canonical_surface(scene, 2048, 0.02, seed + step)[0]});
    torch::Tensor target;
    {
      torch::NoGradGuard no_grad;
      target = scene.field->weights(x);
    }
    // Cross-entropy against the preset weights.
    const auto log_w = torch::log_softmax(mlp->network()->forward(x) * 20.0, -1);
    const auto loss = -(target * log_w).sum(-1).mean();
    adam.zero_grad();
    loss.backward();
    adam.step();
  }
  return mlp;
}

}  // namespace fskin
