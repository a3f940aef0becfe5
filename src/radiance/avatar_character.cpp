#include "fskin/radiance/avatar_character.h"

#include <torch/torch.h>

#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/core/plausibility.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/io/npz.h"

namespace fskin {

namespace fs = std::filesystem;

void save_canonical_character(const RiggedMesh& character, const std::string& path) {
  io::NpzWriter npz;
  npz.add("vertices", character.mesh.vertices.to(torch::kFloat32).contiguous());
  npz.add("faces", character.mesh.faces.to(torch::kInt64).contiguous());
  npz.add("weights", character.weights.to(torch::kFloat32).contiguous());
  npz.add("joints", character.skeleton.rest_joints.to(torch::kFloat32).contiguous());
  npz.add("parents", torch::tensor(character.skeleton.parents, torch::kInt64));
  npz.add_strings("joint_names", character.skeleton.joint_names);
  npz.save(path);
}

RiggedMesh load_canonical_character(const std::string& path) {
  FSKIN_CHECK(fs::exists(path), "{}: missing", path);
  const io::NpzReader npz(path);
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
  RiggedMesh c;
  c.mesh.vertices = floating("vertices");
  c.mesh.faces = integral("faces");
  c.weights = floating("weights");
  c.skeleton.rest_joints = floating("joints");
  const auto parents = integral("parents");
  expect_shape(parents, {-1}, path + ": parents");
  c.skeleton.parents.assign(parents.data_ptr<int64_t>(), parents.data_ptr<int64_t>() + parents.numel());
  c.skeleton.joint_names = npz.strings("joint_names");
  expect_shape(c.mesh.vertices, {-1, 3}, path + ": vertices");
  FSKIN_CHECK(c.mesh.vertices.size(0) > 0, "{}: no vertices", path);
  expect_shape(c.mesh.faces, {-1, 3}, path + ": faces");
  expect_shape(c.weights, {c.mesh.vertices.size(0), -1}, path + ": weights");
  expect_shape(c.skeleton.rest_joints, {c.weights.size(1), 3}, path + ": joints");
  expect_plausible(c.mesh.vertices, path + ": vertices");
  expect_plausible(c.skeleton.rest_joints, path + ": joints");
  FSKIN_CHECK(c.num_joints() == c.weights.size(1) &&
                  static_cast<int64_t>(c.skeleton.joint_names.size()) == c.num_joints(),
              "{}: {} parents and {} joint names for {} weight columns", path, c.skeleton.parents.size(),
              c.skeleton.joint_names.size(), c.weights.size(1));
  // The tree (one root first, parents before children, unique names), faces
  // within the vertices, weights >= 0 summing to 1.
  c.validate(path);
  return c;
}

}  // namespace fskin
