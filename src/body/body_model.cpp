#include "fskin/body/body_model.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/io/npz.h"
#include "fskin/skeleton/forward_kinematics.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {

BodyModel::BodyModel(BodyModelData data, const std::string& source) : data_(std::move(data)) {
  auto& d = data_;
  FSKIN_CHECK(d.v_template.defined(), "{}: missing v_template", source);
  expect_shape(d.v_template, {-1, 3}, source + ": v_template");
  const int64_t V = d.v_template.size(0);
  FSKIN_CHECK(V > 0, "{}: v_template has zero vertices", source);
  const int64_t J = static_cast<int64_t>(d.parents.size());
  FSKIN_CHECK(J > 0, "{}: kintree_table has zero joints", source);
  d.v_template = d.v_template.to(torch::kFloat32).contiguous();
  expect_finite(d.v_template, source + ": v_template");

  FSKIN_CHECK(d.faces.defined(), "{}: missing faces 'f'", source);
  FSKIN_CHECK(!d.faces.is_floating_point(), "{}: faces 'f' must be integers", source);
  d.faces = d.faces.to(torch::kInt64).contiguous();
  Mesh{d.v_template, d.faces, {}}.validate(source);

  expect_shape(d.weights, {V, J}, source + ": weights");
  d.weights = d.weights.to(torch::kFloat32).contiguous();
  expect_finite(d.weights, source + ": weights");
  FSKIN_CHECK((d.weights >= -1e-6).all().item<bool>(), "{}: weights has negative entries", source);
  const double sum_err = (d.weights.sum(1) - 1).abs().max().item<double>();
  FSKIN_CHECK(sum_err < 1e-3, "{}: weights rows must sum to 1 (max deviation {:.3g})", source,
              sum_err);

  FSKIN_CHECK(d.J_regressor.defined() || d.rest_joints.defined(),
              "{}: needs a joint regressor 'J_regressor' or rest joints 'rest_joints'", source);
  if (d.J_regressor.defined()) {
    expect_shape(d.J_regressor, {J, V}, source + ": J_regressor");
    d.J_regressor = d.J_regressor.to(torch::kFloat32).contiguous();
    expect_finite(d.J_regressor, source + ": J_regressor");
  }
  if (d.rest_joints.defined()) {
    expect_shape(d.rest_joints, {J, 3}, source + ": rest_joints");
    d.rest_joints = d.rest_joints.to(torch::kFloat32).contiguous();
    expect_finite(d.rest_joints, source + ": rest_joints");
  }

  if (d.joint_names.empty())
    for (int64_t j = 0; j < J; ++j) d.joint_names.push_back("joint_" + std::to_string(j));
  if (d.shapedirs.defined()) {
    expect_shape(d.shapedirs, {V, 3, -1}, source + ": shapedirs");
    d.shapedirs = d.shapedirs.to(torch::kFloat32).contiguous();
    expect_finite(d.shapedirs, source + ": shapedirs");
  }
  if (d.posedirs.defined()) {
    expect_shape(d.posedirs, {V, 3, 9 * (J - 1)}, source + ": posedirs");
    d.posedirs = d.posedirs.to(torch::kFloat32).contiguous();
    expect_finite(d.posedirs, source + ": posedirs");
  }
  if (d.canonical_pose.defined()) {
    expect_shape(d.canonical_pose, {J, 3}, source + ": canonical_pose");
    d.canonical_pose = d.canonical_pose.to(torch::kFloat32).contiguous();
    expect_finite(d.canonical_pose, source + ": canonical_pose");
  }
  skeleton().validate(source);
}

BodyModel BodyModel::load(const std::string& path) {
  io::NpzReader npz(path);
  for (const char* key : {"v_template", "f", "weights", "kintree_table"})
    FSKIN_CHECK(npz.contains(key), "{}: missing array '{}' (not an SMPL-format model file)", path,
                key);
  FSKIN_CHECK(npz.contains("J_regressor") || npz.contains("rest_joints"),
              "{}: missing array 'J_regressor' (or 'rest_joints'): not an SMPL-format model file", path);
  BodyModelData d;
  d.v_template = npz.tensor("v_template");
  d.faces = npz.tensor("f");
  d.weights = npz.tensor("weights");
  if (npz.contains("J_regressor")) d.J_regressor = npz.tensor("J_regressor");
  if (npz.contains("rest_joints")) d.rest_joints = npz.tensor("rest_joints");
  const auto kintree = npz.tensor("kintree_table").to(torch::kInt64);
  FSKIN_CHECK(kintree.dim() == 2 && kintree.size(0) == 2,
              "{}: kintree_table must be (2, J), got {}", path, shape_string(kintree.sizes()));
  const int64_t J = kintree.size(1);
  FSKIN_CHECK(J > 0, "{}: kintree_table has zero joints", path);
  // Row 0 holds parents (the root's is -1, or 2^32-1 when stored as uint32),
  // row 1 the joint ids; SMPL files store them in id order.
  for (int64_t j = 0; j < J; ++j) {
    FSKIN_CHECK(kintree[1][j].item<int64_t>() == j,
                "{}: kintree_table row 1 must list joints 0..J-1 in order", path);
    const int64_t p = kintree[0][j].item<int64_t>();
    d.parents.push_back(j == 0 ? -1 : p);
  }
  if (npz.contains("joint_names")) d.joint_names = npz.strings("joint_names");
  if (npz.contains("shapedirs")) d.shapedirs = npz.tensor("shapedirs");
  if (npz.contains("posedirs")) d.posedirs = npz.tensor("posedirs");
  if (npz.contains("canonical_pose")) d.canonical_pose = npz.tensor("canonical_pose");
  return BodyModel(std::move(d), path);
}

void BodyModel::save(const std::string& path) const {
  io::NpzWriter npz;
  npz.add("v_template", data_.v_template);
  npz.add("f", data_.faces.to(torch::kInt32));
  npz.add("weights", data_.weights);
  if (data_.J_regressor.defined()) npz.add("J_regressor", data_.J_regressor);
  if (data_.rest_joints.defined()) npz.add("rest_joints", data_.rest_joints);
  auto parents = torch::tensor(data_.parents, torch::kInt64);
  npz.add("kintree_table",
          torch::stack({parents, torch::arange(num_joints(), torch::kInt64)}).to(torch::kInt32));
  npz.add_strings("joint_names", data_.joint_names);
  if (data_.shapedirs.defined()) npz.add("shapedirs", data_.shapedirs);
  if (data_.posedirs.defined()) npz.add("posedirs", data_.posedirs);
  if (data_.canonical_pose.defined()) npz.add("canonical_pose", data_.canonical_pose);
  npz.save(path, /*compress=*/true);
}

Skeleton BodyModel::skeleton() const {
  return Skeleton{data_.joint_names, data_.parents,
                  data_.rest_joints.defined() ? data_.rest_joints.clone()
                                              : torch::matmul(data_.J_regressor, data_.v_template)};
}

Mesh BodyModel::template_mesh() const { return Mesh{data_.v_template, data_.faces, {}}; }

RiggedMesh BodyModel::rig() const { return RiggedMesh{template_mesh(), data_.weights, skeleton()}; }

torch::Tensor pose_features(const torch::Tensor& rotations) {
  expect_shape(rotations, {-1, -1, 3, 3}, "pose_features: rotations");
  const auto eye = torch::eye(3, rotations.options());
  return (rotations.narrow(1, 1, rotations.size(1) - 1) - eye).reshape({rotations.size(0), -1});
}

PosedBody BodyModel::pose(const torch::Tensor& axis_angle, const torch::Tensor& betas,
                          const torch::Tensor& trans, const torch::Tensor& joint_translations) const {
  const int64_t J = num_joints();
  expect_shape(axis_angle, {-1, J, 3}, "BodyModel::pose: axis_angle");
  expect_finite(axis_angle, "BodyModel::pose: axis_angle");
  const int64_t B = axis_angle.size(0);
  // float64 poses are posed in float64 (gradient checks, fitting); anything else in the model's float32.
  const auto dtype = axis_angle.scalar_type() == torch::kFloat64 ? torch::kFloat64 : torch::kFloat32;
  const auto model = [dtype](const torch::Tensor& t) { return t.defined() ? t.to(dtype) : t; };
  auto v_shaped = model(data_.v_template).unsqueeze(0).expand({B, -1, -1});
  if (betas.defined() && betas.numel() > 0) {
    expect_shape(betas, {B, -1}, "BodyModel::pose: betas");
    FSKIN_CHECK(betas.size(1) <= num_betas(), "BodyModel::pose: {} betas given, the model has {}",
                betas.size(1), num_betas());
    const auto dirs = model(data_.shapedirs).narrow(2, 0, betas.size(1));  // [V, 3, S]
    v_shaped = v_shaped + torch::einsum("vcs,bs->bvc", {dirs, betas.to(dtype)});
  }
  // Rest joints given directly do not follow the shape (imported rigs have no shape space).
  const auto joints = data_.rest_joints.defined() ? model(data_.rest_joints).unsqueeze(0).expand({B, -1, -1})
                                                  : torch::matmul(model(data_.J_regressor), v_shaped);  // [B, J, 3]
  const auto rotations = axis_angle_to_matrix(axis_angle.to(dtype));
  auto v_posed = v_shaped;
  if (data_.posedirs.defined())
    v_posed = v_posed + torch::einsum("vcp,bp->bvc", {model(data_.posedirs), pose_features(rotations)});
  if (trans.defined()) {
    expect_shape(trans, {B, 3}, "BodyModel::pose: trans");
    expect_finite(trans, "BodyModel::pose: trans");
  }
  if (joint_translations.defined()) {
    expect_shape(joint_translations, {B, J, 3}, "BodyModel::pose: joint_translations");
    expect_finite(joint_translations, "BodyModel::pose: joint_translations");
  }
  const auto posed = forward_kinematics(data_.parents, joints, rotations, model(trans), model(joint_translations));
  return PosedBody{linear_blend_skinning(v_posed, model(data_.weights), posed.bone_transforms),
                   posed.joints, posed.bone_transforms};
}

torch::Tensor da_pose(const Skeleton& skeleton, double angle_radians) {
  FSKIN_CHECK(skeleton.find("left_hip") >= 0 && skeleton.find("right_hip") >= 0,
              "the Da-pose is SMPL's canonical pose and rotates the joints 'left_hip' and 'right_hip', which this "
              "skeleton ({} joints, first '{}') lacks; use the rest pose (--canonical-pose rest, or the default)",
              skeleton.num_joints(), skeleton.joint_names.front());
  auto pose = torch::zeros({skeleton.num_joints(), 3});
  pose[skeleton.index_of("left_hip")][2] = angle_radians;
  pose[skeleton.index_of("right_hip")][2] = -angle_radians;
  return pose;
}

}  // namespace fskin
