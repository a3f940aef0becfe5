#pragma once
// The pose embedding z_p of INS (eq. 7): every bone transform B_j (relative,
// canonical -> posed, [B, J, 4, 4], docs/conventions.md) becomes a feature
// vector (its translation and a rotation encoding), each bone's features go
// through that bone's own MLP, and the J outputs are concatenated:
//   z_p = [MLP_1(f(B_1)), ..., MLP_J(f(B_J))],  width J * per_bone_dim.
//
// Zero relative pose -> zero embedding (to rounding): the features of the identity
// transform are zero for every encoding (the 6D one subtracts the identity's
// columns), and each bone MLP is centred, MLP_j(f) - MLP_j(0). Together with
// the centred operation maps (operation_map.h) this makes every coupling layer
// the identity at the zero relative pose, which the paper asks of the
// space-varying part (section 3.2, eq. 9) and which INS needs so that the zero
// pose reproduces the canonical shape.
#include <torch/torch.h>

#include <string>
#include <vector>

namespace fskin {

enum class RotationEncoding {
  kEuler,      // 3 angles (the paper); discontinuous at +-pi and at gimbal lock
  kAxisAngle,  // 3 values, axis * angle
  kSixD,       // 6 values, columns (c0, c1) minus the identity's (Zhou et al. 2019), continuous
};

// "euler", "axis_angle", "6d" <-> enum; parsing throws fskin::Error listing the names.
RotationEncoding parse_rotation_encoding(const std::string& name);
std::string to_string(RotationEncoding encoding);
// 3 or 6.
int64_t rotation_encoding_dim(RotationEncoding encoding);

// Euler angles (a, b, c) [..., 3] of rotations [..., 3, 3] written as
// R = Rz(c) Ry(b) Rx(a) (rotate about x, then y, then z, fixed axes);
// a, c in (-pi, pi], b in [-pi/2, pi/2]. The identity gives exactly zero.
torch::Tensor matrix_to_euler_xyz(const torch::Tensor& rotation);

// Per-bone features [B, J, 3 + rotation_encoding_dim]: translation of B_j, then
// its rotation encoding; all zero for the identity transform.
torch::Tensor bone_features(const torch::Tensor& bones, RotationEncoding encoding);

// Which transform of bone j the encoder sees.
enum class PoseFrame {
  // B_j itself (the paper): canonical -> posed in world axes, so bending the
  // spine changes the features of all its descendants (neck, head, arms).
  kGlobal,
  // B_parent(j)^-1 B_j, the joint's own motion relative to its parent (the
  // root keeps B_0): bending the spine changes the spine's features only,
  // as SNARF's pose conditioning sees local joint rotations.
  kParent,
};

// "global", "parent" <-> enum; parsing throws fskin::Error listing the names.
PoseFrame parse_pose_frame(const std::string& name);
std::string to_string(PoseFrame frame);

// B_parent(j)^-1 B_j for j > 0 and B_0 for the root ([B, J, 4, 4]), with the
// rigid inverse [R^T, -R^T t] (bone transforms are rigid, docs/conventions.md).
// The identity pose maps to identities.
torch::Tensor parent_relative_transforms(const torch::Tensor& bones, const std::vector<int64_t>& parents);

struct PoseEncoderOptions {
  int64_t num_bones = 24;
  // 24 bones x 5 = 120, the paper's pose embedding width (Table 4, row 7).
  int64_t per_bone_dim = 5;
  // Two hidden layers of 128 per bone: 24 x 18k = 0.43M parameters, close to the
  // paper's 0.46M bone encoder (Table 4, row 6); the paper gives no widths.
  int64_t hidden_dim = 128;
  int64_t hidden_layers = 2;
  RotationEncoding rotation = RotationEncoding::kEuler;
  PoseFrame frame = PoseFrame::kGlobal;
  // The skeleton's parents (parents[0] == -1); needed by PoseFrame::kParent.
  std::vector<int64_t> parents;
  // Training only: each bone's slice of z_p is zeroed with this probability
  // per frame (and the kept slices scaled by 1 / (1 - p), inverted dropout),
  // so that no coupling layer can rely on a combination of many bones' poses
  // seen together in the training motions. Draws from the default generator.
  double bone_dropout = 0;

  int64_t embedding_dim() const { return num_bones * per_bone_dim; }
  // Throws fskin::Error naming the bad field.
  void validate() const;
};

// Separate weights per bone (the paper encodes "every bone transform using a
// MLP"), evaluated for all bones at once as batched matrix products with
// weights [J, in, out]. Softplus(beta = 100) between layers, as networks/mlp.h.
class PoseEncoderImpl : public torch::nn::Module {
 public:
  explicit PoseEncoderImpl(const PoseEncoderOptions& options = {});
  // bones [B, J, 4, 4] -> z_p [B, J * per_bone_dim]; bone j fills columns
  // [j * per_bone_dim, (j + 1) * per_bone_dim).
  torch::Tensor forward(const torch::Tensor& bones);
  const PoseEncoderOptions& options() const { return options_; }

 private:
  // Uncentred per-bone MLPs: features [B, J, F] -> [B, J, per_bone_dim].
  torch::Tensor per_bone_mlp(const torch::Tensor& features) const;

  PoseEncoderOptions options_;
  std::vector<torch::Tensor> weights_;  // [J, in, out]
  std::vector<torch::Tensor> biases_;   // [J, out], hidden layers only
};
TORCH_MODULE(PoseEncoder);

}  // namespace fskin
