#pragma once
// Per-frame corrections of captured poses, for any rig (InstantAvatar's pose
// refinement, which corrects SMPL's axis-angles, written on bone transforms):
// a small rotation per joint about the joint, in the joint's own frame, and a
// translation of the root. A correction is applied down the kinematic tree,
// so rotating a joint carries its descendants with it, as re-posing the
// skeleton would. The same map adds noise to a dataset's poses
// (radiance/pose_perturbation.h) and learns it back (avatar_training.h).
//
// With canonical joint positions c_j, bones B_j (canonical -> posed) and the
// rotation M_j = T(c_j) R(r_j) T(-c_j) about joint j in canonical space,
// the corrected bones are
//   B'_root = T(size * t) B_root M_root,
//   B'_j    = K_parent B_j M_j,   K_j = B'_j B_j^-1,
// i.e. the joint's local rotation is followed by its parent's correction.
// The translation t is in units of the character's size (the longest side of
// its canonical box, geometry/character_size.h), so one learning rate and one
// regulariser serve any scale.
#include <torch/torch.h>

#include "fskin/skeleton/skeleton.h"

namespace fskin {

// bones [..., J, 4, 4], rotations [..., J, 3] (axis-angle, radians),
// translation [..., 3] (in units of `size`) -> corrected bones [..., J, 4, 4];
// differentiable in all three (exact gradient at zero corrections).
torch::Tensor corrected_bone_transforms(const torch::Tensor& bones, const torch::Tensor& rotations,
                                        const torch::Tensor& translation, const Skeleton& skeleton, double size);

// The learned corrections of a split's frames (one per distinct pose, shared
// by the views that see it), starting at zero, with the frames' given bones
// (a buffer: a saved module holds what it corrects). Each frame's correction
// is a parameter of its own, so that a step's gradients can leave out the
// frames it does not render (forget_gradients).
class PoseCorrectionsImpl : public torch::nn::Module {
 public:
  // given_bones [F, J, 4, 4]: the frames' bones as the dataset gives them.
  explicit PoseCorrectionsImpl(const torch::Tensor& given_bones);
  // The module as saved in `archive` (its frames come from its given bones).
  static std::shared_ptr<PoseCorrectionsImpl> read(torch::serialize::InputArchive& archive);
  int64_t frames() const { return given_.size(0); }
  // Corrected bones [J, 4, 4] of frame `frame`, differentiable in its correction.
  torch::Tensor apply(int64_t frame, const Skeleton& skeleton, double size) const;
  // Every frame's corrected bones [F, J, 4, 4], without gradients.
  torch::Tensor corrected(const Skeleton& skeleton, double size) const;
  // The frame whose given bones equal `bones` [J, 4, 4], or -1.
  int64_t find(const torch::Tensor& bones) const;
  // The bones an image of any split is rendered with: a frame's corrected
  // bones, without gradients, where `given` [J, 4, 4] are that frame's given
  // ones (the novel views of training poses), else `given` itself.
  torch::Tensor bones_for(const torch::Tensor& given, const Skeleton& skeleton, double size) const;
  // The regulariser: squared rotation angles (radians^2) and squared root
  // translation (in units of size), summed per frame, mean over `frames`.
  torch::Tensor squared_size(const std::vector<int64_t>& frames) const;
  // Drops every frame's gradient. Called before a step's backward: the
  // frames the step renders get gradients, the others none, and Adam skips
  // them (with zero gradients its moments would keep moving every frame
  // after each of its rare steps).
  void forget_gradients();
  // Subtracts the mean correction over the frames (per joint, and the root
  // shift's) from every frame, in place. Training calls it before every
  // step: a correction shared by all frames is indistinguishable from a
  // change of the canonical shape (a gauge freedom), and left free it drifts
  // the avatar away from the rig the given poses, and so new poses from the
  // same source, are expressed in. Zero-mean corrections keep the avatar in
  // the given poses' frame; zero-mean noise is then learned, a pose source's
  // common bias is not (it is the rig's, and new poses carry it too).
  void center();
  // Sets every frame's correction to `other`'s, which corrects the same
  // given bones (throws fskin::Error otherwise): a second training pass
  // starts from the first's poses.
  void assign(const PoseCorrectionsImpl& other);
  const torch::Tensor& given_bones() const { return given_; }  // [F, J, 4, 4]
  // The learned tensors by kind (parameters() holds both), for optimisers
  // that step them at different rates: per frame [J, 3] and [3].
  const std::vector<torch::Tensor>& rotation_parameters() const { return rotations_; }
  const std::vector<torch::Tensor>& translation_parameters() const { return translations_; }
  torch::Tensor rotations() const;                              // [F, J, 3], detached
  torch::Tensor translations() const;                           // [F, 3], detached

 private:
  torch::Tensor given_;
  std::vector<torch::Tensor> rotations_, translations_;  // per frame: [J, 3], [3]
};
TORCH_MODULE(PoseCorrections);

// Frames of a split: image i sees frame frame_of[i]; images with equal bone
// transforms share a frame, numbered in the order of first appearance.
std::vector<int64_t> frames_of_images(const torch::Tensor& bone_transforms);
// The bones [F, J, 4, 4] of each frame of `frame_of` (frames_of_images of bone_transforms).
torch::Tensor frame_bone_transforms(const torch::Tensor& bone_transforms, const std::vector<int64_t>& frame_of);
// The frame f whose bones frame_bones[f] equal `bones` [J, 4, 4] exactly, or -1.
int64_t find_frame(const torch::Tensor& frame_bones, const torch::Tensor& bones);

// How far bones [N, J, 4, 4] are from reference bones of the same frames:
// the mean angle between the joints' rotations relative to their parents
// (R_p^T R_j against the reference's; the root's own; degrees: what a
// correction of r radians at one joint changes by |r|) and the mean distance
// between the posed joints B_j c_j and B_ref_j c_j (in units of `size`), over
// frames and joints.
struct PoseError {
  double rotation_degrees = 0, joint_distance = 0;
};
PoseError pose_error(const torch::Tensor& bones, const torch::Tensor& reference, const Skeleton& skeleton, double size);

}  // namespace fskin
