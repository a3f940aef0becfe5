#include "fskin/data/pose_set.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/io/npz.h"

namespace fskin {

PoseSet PoseSet::load(const std::string& path) {
  io::NpzReader npz(path);
  FSKIN_CHECK(npz.contains("poses"), "{}: missing array 'poses' (N, J, 3)", path);
  PoseSet set;
  set.poses = npz.tensor("poses");
  FSKIN_CHECK(set.poses.is_floating_point(), "{}: 'poses' must be floating point", path);
  set.poses = set.poses.to(torch::kFloat32);
  if (set.poses.dim() == 2 && set.poses.size(1) % 3 == 0)  // (N, 3J) as in AMASS files
    set.poses = set.poses.reshape({set.poses.size(0), -1, 3});
  if (npz.contains("trans")) set.trans = npz.tensor("trans").to(torch::kFloat32);
  else if (set.poses.dim() == 3) set.trans = torch::zeros({set.poses.size(0), 3});
  if (npz.contains("joint_names")) set.joint_names = npz.strings("joint_names");
  set.validate(path);
  return set;
}

void PoseSet::save(const std::string& path) const {
  validate(path);
  io::NpzWriter npz;
  npz.add("poses", poses.contiguous());
  npz.add("trans", trans.contiguous());
  if (!joint_names.empty()) npz.add_strings("joint_names", joint_names);
  npz.save(path, /*compress=*/true);
}

void PoseSet::validate(const std::string& context, int64_t expected_joints,
                       const std::vector<std::string>& expected_names) const {
  expect_shape(poses, {-1, expected_joints, 3}, context + ": poses");
  FSKIN_CHECK(poses.size(0) > 0, "{}: pose set is empty", context);
  expect_finite(poses, context + ": poses");
  expect_shape(trans, {poses.size(0), 3}, context + ": trans");
  expect_finite(trans, context + ": trans");
  if (!joint_names.empty())
    FSKIN_CHECK(static_cast<int64_t>(joint_names.size()) == poses.size(1),
                "{}: {} joint names for {} joints", context, joint_names.size(), poses.size(1));
  if (!joint_names.empty() && !expected_names.empty() && joint_names != expected_names)
    fail("{}: joint names do not match the model's (first pose joint '{}', model joint '{}')",
         context, joint_names.front(), expected_names.front());
}

}  // namespace fskin
