#include "import/rig_assembly.h"

#include <torch/torch.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "fskin/core/error.h"
#include "fskin/geometry/character_size.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/skeleton/pose_from_bones.h"

namespace fskin::import_detail {
namespace {

// Coordinates beyond this are corrupt files, not characters (1e12 m is
// beyond any unit mistake and far inside float32's range).
constexpr double kLargestCoordinate = 1e12;
// Clips move joints at most this many character sizes from the origin.
constexpr double kFarthestJointInSizes = 1e4;

}  // namespace

JointOrder order_joints(const std::string& path, const SourceJoints& joints, BodyModelData& data) {
  const auto J = static_cast<int64_t>(joints.names.size());
  FSKIN_CHECK(J >= 1, "{}: the skeleton has no joints", path);
  std::vector<std::string> roots;
  for (int64_t i = 0; i < J; ++i)
    if (joints.parent[i] < 0) roots.push_back(joints.names[i]);
  FSKIN_CHECK(roots.size() == 1, "{}: the skeleton has {} roots ({}{}); fskin needs one root joint", path,
              roots.size(), fmt::format("{}", fmt::join(roots.begin(), roots.begin() + std::min<size_t>(roots.size(), 5), ", ")),
              roots.size() > 5 ? ", ..." : "");
  {
    std::set<std::string> unique(joints.names.begin(), joints.names.end());
    FSKIN_CHECK(unique.size() == joints.names.size(), "{}: two joints share a name; fskin needs unique names", path);
  }
  // Parents first: the source's own order when every parent precedes its
  // children, otherwise breadth-first from the root with children in the
  // source's order. Linear in the joints (a chain may be thousands deep).
  std::vector<std::vector<int>> children(J);
  for (int64_t i = 0; i < J; ++i) {
    FSKIN_CHECK(joints.parent[i] < J, "{}: joint '{}' has parent {} of {}", path, joints.names[i], joints.parent[i], J);
    if (joints.parent[i] >= 0) children[joints.parent[i]].push_back(static_cast<int>(i));
  }
  JointOrder order;
  order.index_of_slot.assign(J, -1);
  const bool source_is_parents_first = [&] {
    for (int64_t i = 0; i < J; ++i)
      if (joints.parent[i] >= i) return false;
    return true;
  }();
  if (source_is_parents_first) {
    for (int64_t i = 0; i < J; ++i) order.slot_of.push_back(static_cast<int>(i));
  } else {
    for (int64_t i = 0; i < J; ++i)
      if (joints.parent[i] < 0) order.slot_of.push_back(static_cast<int>(i));
    for (size_t k = 0; k < order.slot_of.size(); ++k)
      for (int child : children[order.slot_of[k]]) order.slot_of.push_back(child);
    FSKIN_CHECK(static_cast<int64_t>(order.slot_of.size()) == J, "{}: the joint hierarchy has a cycle", path);
  }
  for (int64_t j = 0; j < J; ++j) order.index_of_slot[order.slot_of[j]] = j;
  data.joint_names.clear();
  data.parents.clear();
  data.rest_joints = torch::zeros({J, 3});
  for (int64_t j = 0; j < J; ++j) {
    const int slot = order.slot_of[j];
    data.joint_names.push_back(joints.names[slot]);
    data.parents.push_back(joints.parent[slot] < 0 ? -1 : order.index_of_slot[joints.parent[slot]]);
    const Eigen::Matrix4d bind = joints.inverse_bind[slot].inverse();
    FSKIN_CHECK(bind.allFinite(), "{}: the inverse bind matrix of joint '{}' is singular", path, joints.names[slot]);
    const double largest = bind.block<3, 1>(0, 3).cwiseAbs().maxCoeff();
    FSKIN_CHECK(largest < kLargestCoordinate,
                "{}: joint '{}' is bound at ({:.3g}, {:.3g}, {:.3g}), beyond {:g} in magnitude", path,
                joints.names[slot], bind(0, 3), bind(1, 3), bind(2, 3), kLargestCoordinate);
    for (int a = 0; a < 3; ++a) data.rest_joints[j][a] = bind(a, 3);
  }
  return order;
}

void assemble_mesh(const std::string& path, const SkinnedSoup& soup, const ImportOptions& options,
                   BodyModelData& data, std::vector<std::string>& notes) {
  const auto J = static_cast<int64_t>(data.joint_names.size());
  const int64_t V_in = static_cast<int64_t>(soup.positions.size() / 3);
  FSKIN_CHECK(V_in > 0 && !soup.faces.empty(), "{}: the skinned meshes have no skinned triangles", path);
  FSKIN_CHECK(soup.faces.size() % 3 == 0, "{}: the skinned meshes have {} corner indices, not whole triangles", path,
              soup.faces.size());
  for (const int64_t corner : soup.faces)
    FSKIN_CHECK(corner >= 0 && corner < V_in, "{}: a triangle refers to vertex {} of {}", path, corner, V_in);
  for (size_t i = 0; i < soup.positions.size(); ++i)
    FSKIN_CHECK(std::isfinite(soup.positions[i]) && std::abs(soup.positions[i]) < kLargestCoordinate,
                "{}: vertex {} of the skinned mesh has coordinate {:.3g} (finite and below {:g} in magnitude expected)",
                path, i / 3, soup.positions[i], kLargestCoordinate);
  auto positions = soup.positions;  // from_blob needs a mutable buffer
  auto weights = soup.weights;
  const auto all = torch::from_blob(positions.data(), {V_in, 3}, torch::kFloat64).clone();
  const double tolerance = 1e-6 * character_size(all, path.c_str());
  std::map<std::tuple<int64_t, int64_t, int64_t>, int64_t> welded_index;
  std::vector<int64_t> remap(V_in);
  std::vector<int64_t> keep;  // first input vertex of each welded vertex
  for (int64_t v = 0; v < V_in; ++v) {
    const auto key = std::make_tuple(std::llround(positions[3 * v] / tolerance), std::llround(positions[3 * v + 1] / tolerance),
                                     std::llround(positions[3 * v + 2] / tolerance));
    const auto [it, inserted] = welded_index.emplace(key, static_cast<int64_t>(keep.size()));
    if (inserted) keep.push_back(v);
    remap[v] = it->second;
  }
  std::vector<int64_t> welded_faces;
  int64_t degenerate = 0;
  for (size_t f = 0; f < soup.faces.size(); f += 3) {
    const int64_t a = remap[soup.faces[f]], b = remap[soup.faces[f + 1]], c = remap[soup.faces[f + 2]];
    if (a == b || b == c || a == c) {
      ++degenerate;
      continue;
    }
    welded_faces.insert(welded_faces.end(), {a, b, c});
  }
  FSKIN_CHECK(!welded_faces.empty(), "{}: every triangle of the skinned meshes is degenerate", path);
  notes.push_back(fmt::format("merged {} skinned part(s): {} vertices welded to {} by position{}", soup.parts, V_in,
                              keep.size(), degenerate ? fmt::format(", {} degenerate faces dropped", degenerate) : ""));
  const auto keep_tensor = torch::tensor(keep, torch::kInt64);
  Mesh mesh{all.index_select(0, keep_tensor).to(torch::kFloat32),
            torch::tensor(welded_faces, torch::kInt64).view({-1, 3}), {}};
  auto vertex_weights = torch::from_blob(weights.data(), {V_in, J}, torch::kFloat64).index_select(0, keep_tensor);

  // Keep the closed components.
  const auto components = connected_components(mesh);
  std::vector<torch::Tensor> kept_faces;
  int64_t dropped = 0;
  for (int64_t c = 0; c < components.count; ++c) {
    const auto part = mesh.faces.index({components.face_labels == c});
    if (options.keep_open_parts || analyze_topology(Mesh{mesh.vertices, part, {}}).is_closed_manifold()) {
      kept_faces.push_back(part);
    } else {
      ++dropped;
    }
  }
  FSKIN_CHECK(!kept_faces.empty(),
              "{}: none of the {} connected part(s) of the skinned mesh is closed (every one has holes or "
              "non-manifold edges); fskin learns occupancy and needs a closed surface (--keep-open-parts "
              "imports it anyway, e.g. for its clips)",
              path, components.count);
  if (dropped > 0)
    notes.push_back(fmt::format("dropped {} of {} connected parts that are not closed surfaces", dropped, components.count));
  notes.push_back(options.keep_open_parts ? fmt::format("kept all {} part(s), closed or not", kept_faces.size())
                                          : fmt::format("the result is {} closed part(s)", kept_faces.size()));
  const auto used_faces = torch::cat(kept_faces);
  // Compact: only the vertices the kept faces use, in order.
  auto used = torch::zeros({mesh.num_vertices()}, torch::kBool);
  used.index_put_({used_faces.flatten()}, true);
  const auto used_ids = used.nonzero().flatten();
  auto new_index = torch::full({mesh.num_vertices()}, -1, torch::kInt64);
  new_index.index_put_({used_ids}, torch::arange(used_ids.size(0), torch::kInt64));
  data.v_template = mesh.vertices.index_select(0, used_ids).contiguous();
  data.faces = new_index.index_select(0, used_faces.flatten()).view({-1, 3}).contiguous();
  vertex_weights = vertex_weights.index_select(0, used_ids);
  const auto totals = vertex_weights.sum(1);
  const int64_t unweighted = (totals <= 0).sum().item<int64_t>();
  FSKIN_CHECK(unweighted == 0, "{}: {} vertices of the skinned mesh have no joint weights", path, unweighted);
  data.weights = (vertex_weights / totals.unsqueeze(1)).to(torch::kFloat32).contiguous();
}

void check_key_rotation(double w, double x, double y, double z, const std::string& path, const std::string& where) {
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  FSKIN_CHECK(norm > 0.5 && norm < 2.0, "{}: {} has a quaternion of length {:.3g} (unit quaternions expected)", path,
              where, norm);
}

void check_clip_sampling_cost(size_t key_times, size_t nodes, const std::string& path, const std::string& clip) {
  constexpr double kMostSampledNodeTransforms = 2e8;
  FSKIN_CHECK(static_cast<double>(key_times) * static_cast<double>(nodes) <= kMostSampledNodeTransforms,
              "{}: clip '{}' has {} key times over {} nodes, beyond the {:g} node transforms fskin samples per clip",
              path, clip, key_times, nodes, kMostSampledNodeTransforms);
}

ImportedClip make_clip(const std::string& path, const std::string& name, const std::vector<double>& times,
                       const SkinningAt& skinning_at, const BodyModelData& data, std::vector<std::string>& notes) {
  const auto T = static_cast<int64_t>(times.size());
  const auto J = static_cast<int64_t>(data.joint_names.size());
  FSKIN_CHECK(T >= 1, "{}: clip '{}' has no keyframes", path, name);
  auto bones = torch::zeros({T, J, 4, 4}, torch::kFloat64);
  auto bones_a = bones.accessor<double, 4>();
  for (int64_t t = 0; t < T; ++t) {
    const auto skinning = skinning_at(static_cast<size_t>(t));
    for (int64_t j = 0; j < J; ++j) {
      FSKIN_CHECK(skinning[j].allFinite(), "{}: clip '{}' gives joint '{}' a non-finite transform at {} s", path, name,
                  data.joint_names[j], times[t]);
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) bones_a[t][j][r][c] = skinning[j](r, c);
    }
  }
  // A joint carried more than 10^4 character sizes away is a corrupt clip
  // (a translation of 1e30), not motion: refused before it becomes a pose.
  const double size = character_size(data.v_template);
  const double farthest = bones.index({"...", torch::indexing::Slice(0, 3), 3}).abs().max().item<double>();
  FSKIN_CHECK(farthest <= kFarthestJointInSizes * size,
              "{}: clip '{}' moves a joint {:.3g} m away, beyond {:g} times the character's size ({:.3g} m)", path,
              name, farthest, kFarthestJointInSizes, size);
  const auto pose = pose_from_bone_transforms(data.parents, data.rest_joints, bones);
  ImportedClip clip;
  clip.name = name;
  clip.poses.poses = pose.local_rotations;
  clip.poses.trans = pose.root_translation;
  clip.poses.joint_names = data.joint_names;
  clip.max_joint_drift = pose.max_joint_drift;
  if (times.size() > 1) {
    std::vector<double> steps;
    for (size_t t = 1; t < times.size(); ++t) steps.push_back(times[t] - times[t - 1]);
    std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
    if (steps[steps.size() / 2] > 0) clip.fps = 1.0 / steps[steps.size() / 2];
  }
  if (pose.max_joint_drift > 1e-4 * size) {
    clip.poses.joint_translations = pose.joint_translations;
    notes.push_back(fmt::format("clip '{}' animates translations of non-root joints (up to {:.4g} m, {:.2g} % of the "
                                "character's size): kept as joint translations",
                                name, pose.max_joint_drift, 100 * pose.max_joint_drift / size));
  }
  if (pose.max_scale_deviation > 1e-4)
    notes.push_back(fmt::format("clip '{}' scales joints (by up to {:.3g} %): fskin's joint transforms are rigid, "
                                "so the scale is dropped",
                                name, 100 * pose.max_scale_deviation));
  return clip;
}

}  // namespace fskin::import_detail
