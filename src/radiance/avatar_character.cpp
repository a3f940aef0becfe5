#include "fskin/radiance/avatar_character.h"

#include <torch/torch.h>

#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/core/plausibility.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/io/npz.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

namespace fs = std::filesystem;

void AvatarCharacter::save(const std::string& path) const {
  io::NpzWriter npz;
  npz.add("vertices", vertices.to(torch::kFloat32).contiguous());
  npz.add("faces", faces.to(torch::kInt64).contiguous());
  npz.add("weights", weights.to(torch::kFloat32).contiguous());
  npz.add("joints", joints.to(torch::kFloat32).contiguous());
  npz.add("parents", torch::tensor(parents, torch::kInt64));
  npz.add_strings("joint_names", joint_names);
  npz.save(path);
}

AvatarCharacter AvatarCharacter::load(const std::string& path) {
  FSKIN_CHECK(fs::exists(path), "{}: missing", path);
  const io::NpzReader npz(path);
  AvatarCharacter c;
  const auto floating = [&](const std::string& key) {
    auto t = npz.tensor(key);
    expect_floating(t, path + ": " + key);
    return t.to(torch::kFloat32);
  };
  const auto integral = [&](const std::string& key) {
    auto t = npz.tensor(key);
    FSKIN_CHECK(!t.is_floating_point() && t.scalar_type() != torch::kBool, "{}: {} must hold integers, got {}", path,
                key, std::string(c10::toString(t.scalar_type())));
    return t.to(torch::kInt64).contiguous();
  };
  c.vertices = floating("vertices");
  c.faces = integral("faces");
  c.weights = floating("weights");
  c.joints = floating("joints");
  const auto parents = integral("parents");
  expect_shape(parents, {-1}, path + ": parents");
  c.parents.assign(parents.data_ptr<int64_t>(), parents.data_ptr<int64_t>() + parents.numel());
  c.joint_names = npz.strings("joint_names");
  expect_shape(c.vertices, {-1, 3}, path + ": vertices");
  FSKIN_CHECK(c.vertices.size(0) > 0, "{}: no vertices", path);
  expect_shape(c.faces, {-1, 3}, path + ": faces");
  expect_shape(c.weights, {c.vertices.size(0), -1}, path + ": weights");
  expect_shape(c.joints, {c.weights.size(1), 3}, path + ": joints");
  expect_plausible(c.vertices, path + ": vertices");
  expect_finite(c.weights, path + ": weights");
  FSKIN_CHECK(c.num_joints() == c.weights.size(1) && static_cast<int64_t>(c.joint_names.size()) == c.num_joints(),
              "{}: {} parents and {} joint names for {} weight columns", path, c.parents.size(), c.joint_names.size(),
              c.weights.size(1));
  // The tree (one root first, parents before children, unique names) and finite joints.
  Skeleton{c.joint_names, c.parents, c.joints}.validate(path);
  expect_plausible(c.joints, path + ": joints");
  FSKIN_CHECK(c.faces.numel() == 0 || (c.faces.min().item<int64_t>() >= 0 &&
                                       c.faces.max().item<int64_t>() < c.vertices.size(0)),
              "{}: face indices out of range for {} vertices", path, c.vertices.size(0));
  FSKIN_CHECK(c.weights.min().item<float>() >= 0 && (c.weights.sum(1) - 1).abs().max().item<float>() < 1e-3,
              "{}: skinning weights must be >= 0 with rows summing to 1", path);
  return c;
}

}  // namespace fskin
