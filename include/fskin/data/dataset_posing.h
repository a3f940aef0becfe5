#pragma once
// Bone transforms of new poses exactly as build_dataset computed those of its
// frames: the dataset's body model posed with (pose, trans), rest -> posed,
// made relative to the dataset's canonical pose (canonical.npz), so a model
// trained on the dataset can be queried in any pose of a pose file.
#include <torch/types.h>

#include <string>

#include "fskin/body/body_model.h"
#include "fskin/data/pose_set.h"

namespace fskin {

class DatasetPosing {
 public:
  // The body model is `model_path`, or (empty) the one manifest.json records;
  // throws fskin::Error naming the dataset when that file is missing or is
  // not the model the dataset was built from (other canonical bones).
  static DatasetPosing load(const std::string& data_dir, const std::string& model_path = "");
  // A body model and the canonical pose [J, 3] it was posed in (image datasets
  // record the model and the pose option; radiance/image_dataset.h).
  static DatasetPosing from_model(BodyModel model, const torch::Tensor& canonical_pose);

  const BodyModel& model() const { return model_; }
  int64_t num_joints() const { return model_.num_joints(); }
  // The dataset's canonical pose, axis-angle [J, 3].
  const torch::Tensor& canonical_pose() const { return canonical_pose_; }
  // Canonical -> posed bone transforms [N, J, 4, 4] float32 of every pose of
  // `poses`, validated against the model's joints (errors prefixed `context`).
  torch::Tensor bone_transforms(const PoseSet& poses, const std::string& context) const;

 private:
  DatasetPosing(BodyModel model, torch::Tensor canonical_pose, torch::Tensor canonical_bones);
  BodyModel model_;
  torch::Tensor canonical_pose_;   // [J, 3]
  torch::Tensor canonical_bones_;  // [1, J, 4, 4] rest -> canonical
};

}  // namespace fskin
