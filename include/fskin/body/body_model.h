#pragma once
// An SMPL-format body model (SMPL, SMPL-H, MANO, or fskin's built-in
// character): template mesh, skinning weights, joint regressor, kinematic
// tree, and optional shape and pose blend shapes. Posing follows SMPL:
//   v_shaped = v_template + shapedirs . betas
//   joints   = J_regressor v_shaped
//   v_posed  = v_shaped + posedirs . pose_features(R)   (R_j - I for j >= 1)
//   v        = sum_j w_j B_j v_posed + trans
// fskin never ships or downloads third-party model files.
#include <torch/types.h>

#include <string>
#include <vector>

#include "fskin/geometry/mesh.h"
#include "fskin/skeleton/rigged_mesh.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

struct BodyModelData {
  torch::Tensor v_template;   // [V, 3] float
  torch::Tensor faces;        // [F, 3] int64
  torch::Tensor weights;      // [V, J] float, rows >= 0 and summing to 1
  torch::Tensor J_regressor;  // [J, V] float; optional when rest_joints is given
  // Optional [J, 3]: rest joints given directly (imported rigs: from their
  // inverse bind matrices), used instead of J_regressor v_shaped (key "rest_joints").
  torch::Tensor rest_joints;
  std::vector<int64_t> parents;         // from kintree_table; parents[0] == -1
  std::vector<std::string> joint_names; // "joint_<j>" when the file has none
  torch::Tensor shapedirs;    // optional [V, 3, S]
  torch::Tensor posedirs;     // optional [V, 3, P], P = 9 (J - 1)
  // Optional [J, 3] axis-angle: the pose the model declares as its canonical
  // pose (key "canonical_pose"); datasets use it instead of the rest pose.
  torch::Tensor canonical_pose;
};

struct PosedBody {
  torch::Tensor vertices;         // [B, V, 3]
  torch::Tensor joints;           // [B, J, 3]
  torch::Tensor bone_transforms;  // [B, J, 4, 4] rest -> posed
};

class BodyModel {
 public:
  // Validates everything and throws fskin::Error prefixed with `source`.
  BodyModel(BodyModelData data, const std::string& source);

  // Reads the keys v_template, f, weights, J_regressor, kintree_table and
  // optionally shapedirs, posedirs, joint_names from an .npz file.
  static BodyModel load(const std::string& path);
  void save(const std::string& path) const;

  const BodyModelData& data() const { return data_; }
  int64_t num_joints() const { return static_cast<int64_t>(data_.parents.size()); }
  int64_t num_vertices() const { return data_.v_template.size(0); }
  int64_t num_betas() const { return data_.shapedirs.defined() ? data_.shapedirs.size(2) : 0; }
  // Skeleton with rest joints regressed from the template (betas = 0).
  Skeleton skeleton() const;
  Mesh template_mesh() const;
  // The template, its skinning weights and skeleton as a rig (no blend shapes).
  RiggedMesh rig() const;

  // axis_angle [B, J, 3]; betas [B, S'] (S' <= S, or undefined); trans [B, 3] or undefined;
  // joint_translations [B, J, 3] or undefined (forward_kinematics.h).
  PosedBody pose(const torch::Tensor& axis_angle, const torch::Tensor& betas = {},
                 const torch::Tensor& trans = {}, const torch::Tensor& joint_translations = {}) const;

 private:
  BodyModelData data_;
};

// SMPL's pose-corrective features: (R_j - I) for joints 1..J-1, row-major,
// [B, J, 3, 3] -> [B, 9 (J - 1)].
torch::Tensor pose_features(const torch::Tensor& rotations);

// The papers' canonical "Da-pose" of SMPL skeletons (smpl_skeleton.h): hips
// rotated by +-angle about SMPL's forward (z) axis so the legs stand apart;
// returns axis-angle [J, 3]. Throws fskin::Error naming the skeleton unless
// it has joints "left_hip" and "right_hip".
torch::Tensor da_pose(const Skeleton& skeleton, double angle_radians = 0.5236);

}  // namespace fskin
