#include "fskin/invertible/pose_encoding.h"

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/skeleton/rotations.h"

namespace fskin {

using torch::indexing::Ellipsis;
using torch::indexing::Slice;

RotationEncoding parse_rotation_encoding(const std::string& name) {
  if (name == "euler") return RotationEncoding::kEuler;
  if (name == "axis_angle") return RotationEncoding::kAxisAngle;
  if (name == "6d") return RotationEncoding::kSixD;
  fail("rotation encoding '{}' is unknown; expected euler, axis_angle or 6d", name);
}

std::string to_string(RotationEncoding encoding) {
  switch (encoding) {
    case RotationEncoding::kEuler: return "euler";
    case RotationEncoding::kAxisAngle: return "axis_angle";
    case RotationEncoding::kSixD: return "6d";
  }
  fail("rotation encoding {} is out of range", static_cast<int>(encoding));
}

int64_t rotation_encoding_dim(RotationEncoding encoding) {
  return encoding == RotationEncoding::kSixD ? 6 : 3;
}

torch::Tensor matrix_to_euler_xyz(const torch::Tensor& r) {
  FSKIN_CHECK(r.dim() >= 2 && r.size(-1) == 3 && r.size(-2) == 3,
              "matrix_to_euler_xyz: expected [..., 3, 3], got {}", shape_string(r.sizes()));
  // R = Rz(c) Ry(b) Rx(a) has R20 = -sin b, (R21, R22) = cos b (sin a, cos a),
  // (R10, R00) = cos b (sin c, cos c). The clamp guards rounding past +-1; the
  // gradient is singular at gimbal lock (|b| = pi/2), where Euler angles are.
  const auto a = torch::atan2(r.index({Ellipsis, 2, 1}), r.index({Ellipsis, 2, 2}));
  const auto b = torch::asin((-r.index({Ellipsis, 2, 0})).clamp(-1.0, 1.0));
  const auto c = torch::atan2(r.index({Ellipsis, 1, 0}), r.index({Ellipsis, 0, 0}));
  return torch::stack({a, b, c}, -1);
}

torch::Tensor bone_features(const torch::Tensor& bones, RotationEncoding encoding) {
  expect_shape(bones, {-1, -1, 4, 4}, "bone_features: bones");
  const auto translation = bones.index({Ellipsis, Slice(0, 3), 3});
  const auto rotation = bones.index({Ellipsis, Slice(0, 3), Slice(0, 3)});
  torch::Tensor encoded;
  switch (encoding) {
    case RotationEncoding::kEuler: encoded = matrix_to_euler_xyz(rotation); break;
    case RotationEncoding::kAxisAngle: encoded = matrix_to_axis_angle(rotation); break;
    case RotationEncoding::kSixD:
      // The identity's (c0, c1) = (1,0,0, 0,1,0) is subtracted so that the zero
      // relative pose gives zero features, as it does for the other encodings.
      encoded = matrix_to_rotation_6d(rotation) -
                torch::tensor({1.0, 0.0, 0.0, 0.0, 1.0, 0.0}, bones.options());
      break;
  }
  return torch::cat({translation, encoded}, -1);
}

PoseFrame parse_pose_frame(const std::string& name) {
  if (name == "global") return PoseFrame::kGlobal;
  if (name == "parent") return PoseFrame::kParent;
  fail("pose frame '{}' is unknown; expected global or parent", name);
}

std::string to_string(PoseFrame frame) {
  switch (frame) {
    case PoseFrame::kGlobal: return "global";
    case PoseFrame::kParent: return "parent";
  }
  fail("pose frame {} is out of range", static_cast<int>(frame));
}

torch::Tensor parent_relative_transforms(const torch::Tensor& bones, const std::vector<int64_t>& parents) {
  expect_shape(bones, {-1, static_cast<int64_t>(parents.size()), 4, 4}, "parent_relative_transforms: bones");
  FSKIN_CHECK(!parents.empty() && parents[0] == -1, "parent_relative_transforms: parents[0] must be -1");
  std::vector<int64_t> parent_of_child(parents.begin() + 1, parents.end());
  for (size_t j = 0; j < parent_of_child.size(); ++j) {
    FSKIN_CHECK(parent_of_child[j] >= 0 && parent_of_child[j] < static_cast<int64_t>(j + 1),
                "parent_relative_transforms: parents[{}] = {} is not an earlier joint", j + 1, parent_of_child[j]);
  }
  const auto index = torch::tensor(parent_of_child, torch::TensorOptions(torch::kLong).device(bones.device()));
  const auto parent = bones.index_select(1, index);  // [B, J-1, 4, 4]
  const auto rotation_t = parent.index({Ellipsis, Slice(0, 3), Slice(0, 3)}).transpose(-1, -2);
  const auto translation = parent.index({Ellipsis, Slice(0, 3), Slice(3, 4)});
  const auto bottom = parent.index({Ellipsis, Slice(3, 4), Slice()});
  const auto inverse = torch::cat({torch::cat({rotation_t, -torch::matmul(rotation_t, translation)}, -1), bottom}, -2);
  const auto children = torch::matmul(inverse, bones.index({Slice(), Slice(1)}));
  return torch::cat({bones.index({Slice(), Slice(0, 1)}), children}, 1);
}

void PoseEncoderOptions::validate() const {
  FSKIN_CHECK(num_bones > 0, "PoseEncoderOptions: num_bones must be positive, got {}", num_bones);
  FSKIN_CHECK(per_bone_dim > 0, "PoseEncoderOptions: per_bone_dim must be positive, got {}", per_bone_dim);
  FSKIN_CHECK(hidden_dim > 0, "PoseEncoderOptions: hidden_dim must be positive, got {}", hidden_dim);
  FSKIN_CHECK(hidden_layers >= 0, "PoseEncoderOptions: hidden_layers must be >= 0, got {}", hidden_layers);
  FSKIN_CHECK(frame == PoseFrame::kGlobal || static_cast<int64_t>(parents.size()) == num_bones,
              "PoseEncoderOptions: the parent frame needs the parents of all {} bones, got {}", num_bones,
              parents.size());
  FSKIN_CHECK(bone_dropout >= 0 && bone_dropout < 1, "PoseEncoderOptions: bone_dropout must be in [0, 1), got {}",
              bone_dropout);
}

PoseEncoderImpl::PoseEncoderImpl(const PoseEncoderOptions& o) : options_(o) {
  o.validate();
  const int64_t feature_dim = 3 + rotation_encoding_dim(o.rotation);
  for (int64_t l = 0; l <= o.hidden_layers; ++l) {
    const int64_t in = l == 0 ? feature_dim : o.hidden_dim;
    const int64_t out = l == o.hidden_layers ? o.per_bone_dim : o.hidden_dim;
    // PyTorch's Linear default, per bone. Not zero in the last layer: the
    // operation maps' last layers are zero (Appendix C.1), and a zero pose
    // embedding on top would leave them without gradient.
    const double bound = 1.0 / std::sqrt(static_cast<double>(in));
    weights_.push_back(register_parameter("weight" + std::to_string(l),
                                          torch::empty({o.num_bones, in, out}).uniform_(-bound, bound)));
    // The last layer has no bias: the centring below would cancel it.
    if (l < o.hidden_layers) {
      biases_.push_back(register_parameter("bias" + std::to_string(l),
                                           torch::empty({o.num_bones, out}).uniform_(-bound, bound)));
    }
  }
}

torch::Tensor PoseEncoderImpl::per_bone_mlp(const torch::Tensor& features) const {
  torch::Tensor h = features.unsqueeze(-2);  // [B, J, 1, F] @ [J, F, out] -> [B, J, 1, out]
  for (size_t l = 0; l < weights_.size(); ++l) {
    h = torch::matmul(h, weights_[l]);
    if (l < biases_.size()) h = torch::softplus(h + biases_[l].unsqueeze(-2), 100.0, 20.0);
  }
  return h.squeeze(-2);
}

torch::Tensor PoseEncoderImpl::forward(const torch::Tensor& bones) {
  expect_shape(bones, {-1, options_.num_bones, 4, 4}, "PoseEncoder: bones");
  expect_floating(bones, "PoseEncoder: bones");
  expect_finite(bones, "PoseEncoder: bones");
  FSKIN_CHECK(bones.scalar_type() == weights_[0].scalar_type(),
              "PoseEncoder: bones are {} but the parameters are {}", std::string(c10::toString(bones.scalar_type())),
              std::string(c10::toString(weights_[0].scalar_type())));
  const auto features =
      bone_features(options_.frame == PoseFrame::kParent ? parent_relative_transforms(bones, options_.parents) : bones,
                    options_.rotation);
  // Centring: the identity transform has zero features, so it maps to exactly 0.
  const auto zero = torch::zeros({1, features.size(1), features.size(2)}, features.options());
  auto embedding = per_bone_mlp(features) - per_bone_mlp(zero);
  if (is_training() && options_.bone_dropout > 0) {
    const double keep = 1.0 - options_.bone_dropout;
    embedding = embedding * (torch::bernoulli(torch::full({bones.size(0), options_.num_bones, 1}, keep,
                                                          embedding.options())) /
                             keep);
  }
  return embedding.reshape({bones.size(0), options_.embedding_dim()});
}

}  // namespace fskin
