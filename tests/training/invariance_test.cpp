// The same training problem in other units and orientations trains the same:
// every default length is relative to the character's size (character_size.h)
// and the skinning grid follows the character's extents (VoxelBox::fit).
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <cstdio>

#include "fskin/evaluation/evaluation.h"
#include "fskin/skeleton/rotations.h"
#include "fskin/training/occupancy_training.h"
#include "test_util.h"
#include "training/synthetic_limb.h"
#include "training/tiny_training.h"

namespace fskin {
namespace {

// x -> s R x applied to a whole problem: points, joints, bone transforms
// (B -> T B T^-1 with T = [s R | 0]) and local rotations (conjugated by R, so
// the axis-angle vectors rotate with R).
struct Similarity {
  double scale = 1;
  torch::Tensor rotation = torch::eye(3);

  torch::Tensor points(const torch::Tensor& x) const { return scale * torch::matmul(x, rotation.t()); }
  torch::Tensor bones(const torch::Tensor& b) const {
    auto out = b.clone();
    out.narrow(-2, 0, 3).narrow(-1, 0, 3).copy_(torch::matmul(torch::matmul(rotation, b.narrow(-2, 0, 3).narrow(-1, 0, 3)), rotation.t()));
    out.narrow(-2, 0, 3).select(-1, 3).copy_(scale * torch::matmul(b.narrow(-2, 0, 3).select(-1, 3), rotation.t()));
    return out;
  }
  torch::Tensor pose(const torch::Tensor& p) const { return torch::matmul(p, rotation.t()); }
};

class SimilarSource : public BatchSource {
 public:
  SimilarSource(const BatchSource& inner, Similarity similarity) : inner_(inner), t_(std::move(similarity)) {
    skeleton_ = inner.skeleton();
    skeleton_.joints = t_.points(skeleton_.joints);
    skeleton_.extent = t_.points(skeleton_.extent);
  }
  int64_t num_frames() const override { return inner_.num_frames(); }
  const CanonicalSkeleton& skeleton() const override { return skeleton_; }
  OccupancyBatch batch(int64_t frames, int64_t surface, int64_t uniform, uint64_t seed) const override {
    auto b = inner_.batch(frames, surface, uniform, seed);
    return {t_.points(b.points), b.occupancy, t_.bones(b.bone_transforms), t_.pose(b.pose)};
  }
  std::vector<OccupancyFrame> transformed(std::vector<OccupancyFrame> frames) const {
    for (auto& f : frames) {
      f.points = t_.points(f.points);
      f.bone_transforms = t_.bones(f.bone_transforms);
      f.pose = t_.pose(f.pose);
    }
    return frames;
  }

 private:
  const BatchSource& inner_;
  Similarity t_;
  CanonicalSkeleton skeleton_;
};

torch::Tensor quarter_turn(int axis) {
  auto aa = torch::zeros({3});
  aa[axis] = M_PI / 2;
  return axis_angle_to_matrix(aa);
}

double trained_iou(const Similarity& similarity, const std::string& name, uint64_t seed = 0) {
  const testing::SyntheticLimb limb(testing::training_angles());
  const SimilarSource source(limb, similarity);
  const auto run = testing::temp_dir("invariance_" + name);
  TrainConfig config = testing::tiny_config();
  config.steps = 400;
  config.seed = seed;
  // The demo's schedule (warm-up, cosine decay): the tiny config's constant
  // rate lets some runs spike, whatever the units.
  config.warmup_steps = 50;
  config.decay_fraction = 0.5;
  config.checkpoint_every = 400;
  train(config, source, {run.string(), false, false, nullptr});
  auto model = load_trained_model(run.string(), source.skeleton());
  const auto frames = source.transformed(testing::SyntheticLimb::frames({-1.0, 0.3, 1.1}, 2000, 2000));
  const auto metrics = evaluate(*model, frames, "test");
  std::filesystem::remove_all(run);
  std::printf("%-10s IoU_surf %.4f IoU_bbox %.4f\n", name.c_str(), metrics.mean_iou_surf, metrics.mean_iou_bbox);
  return metrics.mean_iou_surf;
}

TEST(Invariance, ScaledAndRotatedLimbTrainsToTheSameIou) {
  const double reference = trained_iou({}, "reference");
  EXPECT_GT(reference, 0.6);
  for (double scale : {0.1, 10.0})
    EXPECT_NEAR(trained_iou({scale, torch::eye(3)}, "scale_" + std::to_string(scale)), reference, 0.01) << scale;
  for (int axis = 0; axis < 3; ++axis)
    EXPECT_NEAR(trained_iou({1.0, quarter_turn(axis)}, "turn_" + std::to_string(axis)), reference, 0.01) << axis;
}

}  // namespace
}  // namespace fskin
