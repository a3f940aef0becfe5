#include "fskin/data/dataset_posing.h"

#include <torch/torch.h>

#include <filesystem>

#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/data/dataset_frame.h"
#include "fskin/skeleton/forward_kinematics.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

DatasetPosing::DatasetPosing(BodyModel model, torch::Tensor canonical_pose, torch::Tensor canonical_bones)
    : model_(std::move(model)), canonical_pose_(std::move(canonical_pose)),
      canonical_bones_(std::move(canonical_bones)) {}

DatasetPosing DatasetPosing::load(const std::string& data_dir, const std::string& model_path) {
  namespace fs = std::filesystem;
  const auto manifest_path = (fs::path(data_dir) / "manifest.json").string();
  std::string path = model_path;
  if (path.empty()) {
    nlohmann::json manifest;
    try {
      manifest = nlohmann::json::parse(read_file(manifest_path));
    } catch (const nlohmann::json::exception& e) {
      fail("{}: not a valid dataset manifest ({})", manifest_path, e.what());
    }
    path = manifest.value("model", "");
    FSKIN_CHECK(!path.empty(), "{} records no body model; pass the model .npz (--model)", manifest_path);
    FSKIN_CHECK(fs::exists(path),
                "{} records the body model '{}', which does not exist here (a relative path is relative to "
                "where `fskin data build` ran); pass the model .npz (--model)",
                manifest_path, path);
  }
  BodyModel model = BodyModel::load(path);
  const auto canonical = DatasetFrame::load((fs::path(data_dir) / "canonical.npz").string(), false);
  FSKIN_CHECK(canonical.pose.defined() && canonical.pose.dim() == 2 && canonical.pose.size(0) == model.num_joints(),
              "{}: the model {} has {} joints, the dataset's canonical pose {}", data_dir, path, model.num_joints(),
              canonical.pose.defined() ? canonical.pose.size(0) : 0);
  const auto pose = canonical.pose.to(torch::kFloat32);
  const auto bones = model.pose(pose.unsqueeze(0)).bone_transforms;  // [1, J, 4, 4] rest -> canonical
  FSKIN_CHECK(torch::allclose(bones[0], canonical.bone_transforms_rest.to(bones.dtype()), 1e-4, 1e-5),
              "{}: the body model {} is not the one the dataset was built from (its canonical bone transforms "
              "differ from canonical.npz)",
              data_dir, path);
  return DatasetPosing(std::move(model), pose, bones);
}

DatasetPosing DatasetPosing::from_model(BodyModel model, const torch::Tensor& canonical_pose) {
  const auto pose = canonical_pose.to(torch::kFloat32);
  const auto bones = model.pose(pose.unsqueeze(0)).bone_transforms;  // [1, J, 4, 4] rest -> canonical
  return DatasetPosing(std::move(model), pose, bones);
}

torch::Tensor DatasetPosing::bone_transforms(const PoseSet& poses, const std::string& context) const {
  poses.validate(context, model_.num_joints(), model_.data().joint_names);
  const auto posed = model_.pose(poses.poses.to(torch::kFloat32), {}, poses.trans.to(torch::kFloat32),
                                 poses.joint_translations);
  return relative_bone_transforms(posed.bone_transforms, canonical_bones_).to(torch::kFloat32).contiguous();
}

}  // namespace fskin
