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
  if (npz.contains("joint_translations")) {
    set.joint_translations = npz.tensor("joint_translations");
    FSKIN_CHECK(set.joint_translations.is_floating_point(), "{}: 'joint_translations' must be floating point", path);
    set.joint_translations = set.joint_translations.to(torch::kFloat32);
  }
  if (npz.contains("joint_names")) set.joint_names = npz.strings("joint_names");
  if (npz.contains("clip_names")) {
    set.clip_names = npz.strings("clip_names");
    FSKIN_CHECK(npz.contains("clip_starts"), "{}: 'clip_names' without 'clip_starts'", path);
    const auto starts = npz.tensor("clip_starts").to(torch::kInt64).flatten();
    for (int64_t i = 0; i < starts.size(0); ++i) set.clip_starts.push_back(starts[i].item<int64_t>());
  }
  set.validate(path);
  return set;
}

PoseSet PoseSet::slice(int64_t first, int64_t last) const {
  FSKIN_CHECK(first >= 0 && first < last && last <= size(), "PoseSet::slice: [{}, {}) of {} poses", first, last,
              size());
  PoseSet out;
  out.poses = poses.slice(0, first, last);
  out.trans = trans.slice(0, first, last);
  if (joint_translations.defined()) out.joint_translations = joint_translations.slice(0, first, last);
  out.joint_names = joint_names;
  return out;
}

void PoseSet::save(const std::string& path) const {
  validate(path);
  io::NpzWriter npz;
  npz.add("poses", poses.contiguous());
  npz.add("trans", trans.contiguous());
  if (joint_translations.defined()) npz.add("joint_translations", joint_translations.contiguous());
  if (!joint_names.empty()) npz.add_strings("joint_names", joint_names);
  if (!clip_names.empty()) {
    npz.add_strings("clip_names", clip_names);
    npz.add("clip_starts", torch::tensor(clip_starts, torch::kInt64));
  }
  npz.save(path, /*compress=*/true);
}

void PoseSet::validate(const std::string& context, int64_t expected_joints,
                       const std::vector<std::string>& expected_names) const {
  expect_shape(poses, {-1, expected_joints, 3}, context + ": poses");
  FSKIN_CHECK(poses.size(0) > 0, "{}: pose set is empty", context);
  expect_finite(poses, context + ": poses");
  expect_shape(trans, {poses.size(0), 3}, context + ": trans");
  expect_finite(trans, context + ": trans");
  if (joint_translations.defined()) {
    expect_shape(joint_translations, {poses.size(0), poses.size(1), 3}, context + ": joint_translations");
    expect_finite(joint_translations, context + ": joint_translations");
  }
  if (!joint_names.empty())
    FSKIN_CHECK(static_cast<int64_t>(joint_names.size()) == poses.size(1),
                "{}: {} joint names for {} joints", context, joint_names.size(), poses.size(1));
  FSKIN_CHECK(clip_names.size() == clip_starts.size(), "{}: {} clip names for {} clip starts", context,
              clip_names.size(), clip_starts.size());
  for (size_t c = 0; c < clip_starts.size(); ++c)
    FSKIN_CHECK(clip_starts[c] >= 0 && clip_starts[c] < poses.size(0) && (c == 0 ? clip_starts[c] == 0 : clip_starts[c] > clip_starts[c - 1]),
                "{}: clip '{}' starts at pose {}: clip starts must increase from 0 within the {} poses", context,
                clip_names[c], clip_starts[c], poses.size(0));
  if (!joint_names.empty() && !expected_names.empty() && joint_names != expected_names)
    fail("{}: joint names do not match the model's (first pose joint '{}', model joint '{}')",
         context, joint_names.front(), expected_names.front());
}

}  // namespace fskin
