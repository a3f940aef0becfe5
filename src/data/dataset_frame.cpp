#include "fskin/data/dataset_frame.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/plausibility.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/io/npz.h"

namespace fskin {

void DatasetFrame::validate(const std::string& context) const {
  expect_shape(points, {-1, 3}, context + ": points");
  FSKIN_CHECK(points.scalar_type() == torch::kFloat32, "{}: points must be float32, got {}", context,
              c10::toString(points.scalar_type()));
  expect_plausible(points, context + ": points");
  expect_shape(occupancy, {points.size(0)}, context + ": occupancy");
  FSKIN_CHECK(occupancy.scalar_type() == torch::kUInt8, "{}: occupancy must be uint8", context);
  FSKIN_CHECK(occupancy.numel() == 0 || occupancy.max().item<int64_t>() <= 1,
              "{}: occupancy values must be 0 (outside) or 1 (inside), found {}", context,
              occupancy.numel() == 0 ? 0 : occupancy.max().item<int64_t>());
  FSKIN_CHECK(num_uniform >= 0 && num_uniform <= points.size(0),
              "{}: num_uniform {} outside [0, {}]", context, num_uniform, points.size(0));
  expect_shape(bone_transforms, {-1, 4, 4}, context + ": bone_transforms");
  const int64_t J = bone_transforms.size(0);
  expect_shape(bone_transforms_rest, {J, 4, 4}, context + ": bone_transforms_rest");
  expect_shape(pose, {J, 3}, context + ": pose");
  expect_shape(trans, {3}, context + ": trans");
  expect_shape(box, {2, 3}, context + ": box");
  expect_plausible(bone_transforms, context + ": bone_transforms");
  expect_plausible(bone_transforms_rest, context + ": bone_transforms_rest");
  expect_plausible(pose, context + ": pose");
  if (vertices.defined()) {
    expect_shape(vertices, {-1, 3}, context + ": vertices");
    expect_shape(faces, {-1, 3}, context + ": faces");
    expect_plausible(vertices, context + ": vertices");
  }
  if (joints.defined()) {
    expect_shape(joints, {J, 3}, context + ": joints");
    expect_plausible(joints, context + ": joints");
  }
}

void DatasetFrame::save(const std::string& path) const {
  validate(path);
  io::NpzWriter npz;
  npz.add("points", points.to(torch::kFloat32).contiguous());
  npz.add("occupancy", occupancy.contiguous());
  npz.add("num_uniform", torch::tensor({num_uniform}, torch::kInt64));
  npz.add("bone_transforms", bone_transforms.to(torch::kFloat32).contiguous());
  npz.add("bone_transforms_rest", bone_transforms_rest.to(torch::kFloat32).contiguous());
  npz.add("pose", pose.to(torch::kFloat32).contiguous());
  npz.add("trans", trans.to(torch::kFloat32).contiguous());
  npz.add("box", box.to(torch::kFloat32).contiguous());
  if (vertices.defined()) {
    npz.add("vertices", vertices.to(torch::kFloat32).contiguous());
    npz.add("faces", faces.to(torch::kInt64).contiguous());
  }
  if (joints.defined()) npz.add("joints", joints.to(torch::kFloat32).contiguous());
  // Stored, not deflated: float point clouds barely compress (-25 %) and deflate
  // took longer than posing, sampling and the inside test together.
  npz.save(path, /*compress=*/false);
}

DatasetFrame DatasetFrame::load(const std::string& path, bool with_mesh) {
  io::NpzReader npz(path);
  DatasetFrame frame;
  frame.points = npz.tensor("points");
  frame.occupancy = npz.tensor("occupancy");
  const auto num_uniform = npz.tensor("num_uniform");
  FSKIN_CHECK(num_uniform.numel() == 1, "{}: num_uniform must hold one value", path);
  frame.num_uniform = num_uniform.to(torch::kInt64).item<int64_t>();
  frame.bone_transforms = npz.tensor("bone_transforms");
  frame.bone_transforms_rest = npz.tensor("bone_transforms_rest");
  frame.pose = npz.tensor("pose");
  frame.trans = npz.tensor("trans");
  frame.box = npz.tensor("box");
  if (with_mesh && npz.contains("vertices")) {
    frame.vertices = npz.tensor("vertices");
    frame.faces = npz.tensor("faces");
  }
  if (npz.contains("joints")) frame.joints = npz.tensor("joints");
  frame.validate(path);
  return frame;
}

}  // namespace fskin
