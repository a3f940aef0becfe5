#include "fskin/inference/posed_meshing.h"

#include <fmt/format.h>
#include <torch/torch.h>

#include <chrono>
#include <cmath>

#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/losses/skinning_prior.h"
#include "fskin/util/progress.h"

namespace fskin {
namespace {

using Clock = std::chrono::steady_clock;

void check_skeleton(const CanonicalSkeleton& skeleton) {
  expect_shape(skeleton.extent, {-1, 3}, "meshing: skeleton extent");
  FSKIN_CHECK(skeleton.extent.size(0) > 0, "meshing: the skeleton has no extent points");
  expect_shape(skeleton.joints, {-1, 3}, "meshing: skeleton joints");
}

void prepare_for_inference(OccupancyModel& model) {
  model.train(false);
  model.freeze_for_inference();
}

MeshingResult extract(const ScalarField& field, const Box& box, const PosedMeshingOptions& options,
                      const MiseProgress& progress, Clock::time_point start) {
  MiseOptions mise_options = options.mise;
  mise_options.refinement_steps = options.surface_steps;
  auto found = mise(field, box.min, box.max, mise_options, progress);
  MeshingResult result{std::move(found.mesh), found.stats, box, 0.0};
  if (options.largest_component && result.mesh.num_faces() > 0) result.mesh = keep_largest_component(result.mesh);
  result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

}  // namespace

Box posed_meshing_box(OccupancyModel& model, const CanonicalSkeleton& skeleton, const torch::Tensor& bones,
                      double padding) {
  check_skeleton(skeleton);
  const int64_t J = skeleton.joints.size(0);
  expect_shape(bones, {J, 4, 4}, "meshing: bones");
  torch::NoGradGuard no_grad;
  prepare_for_inference(model);
  const auto device = module_device(model);
  const auto extent = skeleton.extent.to(device, torch::kFloat32).unsqueeze(0);  // [1, M, 3]
  const auto b = bones.to(device, torch::kFloat32).unsqueeze(0);
  // The model's own canonical skinning weights; methods without any (the
  // posed-space baselines) use the skeleton's nearest-bone prior instead.
  auto* field = model.canonical_skinning_field();
  const auto weights = field != nullptr ? field->weights(extent)
                                        : nearest_bone_weights(skeleton, extent[0].cpu()).to(device).unsqueeze(0);
  const auto skinned = linear_blend_skinning(extent, weights, b)[0].cpu();
  const auto joints = transform_points(bones.to(torch::kFloat32), skeleton.joints.to(torch::kFloat32));
  return padded_bounds(torch::cat({skinned, joints}), padding);
}

MeshingResult mesh_posed(OccupancyModel& model, const CanonicalSkeleton& skeleton,
                         const torch::Tensor& bones, const torch::Tensor& pose, const PosedMeshingOptions& options,
                         const MiseProgress& progress) {
  const auto start = Clock::now();
  const int64_t J = skeleton.joints.size(0);
  expect_shape(pose, {J, 3}, "meshing: pose");
  const Box box = posed_meshing_box(model, skeleton, bones, options.padding);
  torch::NoGradGuard no_grad;
  const auto device = module_device(model);
  const auto b = bones.to(device, torch::kFloat32).unsqueeze(0), p = pose.to(device, torch::kFloat32).unsqueeze(0);
  const ScalarField field = [&](const torch::Tensor& points) {
    return model.predict(points.to(device).unsqueeze(0), b, p, Aggregation::Max).logits.squeeze(0).cpu();
  };
  return extract(field, box, options, progress, start);
}

MeshingResult mesh_canonical(OccupancyModel& model, const CanonicalSkeleton& skeleton,
                             const torch::Tensor& pose, const PosedMeshingOptions& options,
                             const MiseProgress& progress) {
  const auto start = Clock::now();
  expect_shape(pose, {skeleton.joints.size(0), 3}, "meshing: canonical pose");
  const Box box = canonical_bounds(skeleton, options.padding);
  torch::NoGradGuard no_grad;
  prepare_for_inference(model);
  const auto device = module_device(model);
  const auto p = pose.to(device, torch::kFloat32).unsqueeze(0);
  const ScalarField field = [&](const torch::Tensor& points) {
    return model.canonical_logits(points.to(device).unsqueeze(0), p).reshape({-1}).cpu();
  };
  return extract(field, box, options, progress, start);
}

void mesh_pose_sequence(OccupancyModel& model, const CanonicalSkeleton& skeleton,
                        const torch::Tensor& bones, const torch::Tensor& poses, const PosedMeshingOptions& options,
                        const std::function<void(int64_t, MeshingResult&&)>& on_mesh, bool progress) {
  const int64_t J = skeleton.joints.size(0);
  expect_shape(bones, {-1, J, 4, 4}, "meshing: bones");
  expect_shape(poses, {bones.size(0), J, 3}, "meshing: poses");
  ProgressBar bar("meshing poses", bones.size(0), progress);
  for (int64_t n = 0; n < bones.size(0); ++n) {
    auto result = mesh_posed(model, skeleton, bones[n], poses[n], options);
    const auto status = fmt::format("{:.1f} s, {} faces", result.seconds, result.mesh.num_faces());
    on_mesh(n, std::move(result));
    bar.advance(1, status);
  }
  bar.finish();
}

torch::Tensor repose_vertices(OccupancyModel& model, const Mesh& canonical, const torch::Tensor& bones,
                              int64_t batch, bool progress) {
  canonical.validate("re-posing: canonical mesh");
  expect_shape(bones, {-1, -1, 4, 4}, "re-posing: bones");
  FSKIN_CHECK(batch >= 1, "re-posing: batch must be >= 1, got {}", batch);
  torch::NoGradGuard no_grad;
  prepare_for_inference(model);
  const int64_t N = bones.size(0);
  const auto device = module_device(model);
  std::vector<torch::Tensor> frames;
  ProgressBar bar("re-posing", N, progress);
  for (int64_t begin = 0; begin < N; begin += batch) {
    const int64_t n = std::min(batch, N - begin);
    const auto x = canonical.vertices.to(device, torch::kFloat32).unsqueeze(0).expand({n, -1, 3}).contiguous();
    frames.push_back(model.repose(x, bones.narrow(0, begin, n).to(device, torch::kFloat32)).cpu());
    bar.advance(n);
  }
  bar.finish();
  return torch::cat(frames);
}

}  // namespace fskin
