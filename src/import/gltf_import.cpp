#include "fskin/import/gltf_import.h"

#include <torch/torch.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <functional>
#include <tuple>

#include "fskin/core/error.h"
#include "fskin/geometry/character_size.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/skeleton/pose_from_bones.h"
#include "io/gltf_file.h"

namespace fskin {
namespace {

using Matrix4 = Eigen::Matrix4d;

// A node's local transform: its matrix, or translation * rotation * scale.
struct Trs {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  bool has_matrix = false;
  Matrix4 matrix = Matrix4::Identity();

  Matrix4 to_matrix() const {
    if (has_matrix) return matrix;
    Matrix4 m = Matrix4::Identity();
    m.block<3, 3>(0, 0) = rotation.normalized().toRotationMatrix() * scale.asDiagonal();
    m.block<3, 1>(0, 3) = translation;
    return m;
  }
};

Trs rest_trs(const tinygltf::Node& node) {
  Trs t;
  if (node.matrix.size() == 16) {
    t.has_matrix = true;
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) t.matrix(r, c) = node.matrix[4 * c + r];  // column-major
    return t;
  }
  if (node.translation.size() == 3) t.translation = {node.translation[0], node.translation[1], node.translation[2]};
  if (node.rotation.size() == 4)  // glTF: (x, y, z, w)
    t.rotation = Eigen::Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);
  if (node.scale.size() == 3) t.scale = {node.scale[0], node.scale[1], node.scale[2]};
  return t;
}

// Global transforms of every node from local ones and the parent map.
std::vector<Matrix4> global_transforms(const std::vector<Trs>& locals, const std::vector<int>& parent) {
  std::vector<Matrix4> global(locals.size());
  std::vector<char> done(locals.size(), 0);
  std::function<const Matrix4&(int)> get = [&](int n) -> const Matrix4& {
    if (!done[n]) {
      global[n] = parent[n] < 0 ? locals[n].to_matrix() : Matrix4(get(parent[n]) * locals[n].to_matrix());
      done[n] = 1;
    }
    return global[n];
  };
  for (size_t n = 0; n < locals.size(); ++n) get(static_cast<int>(n));
  return global;
}

std::string node_name(const tinygltf::Model& model, int n) {
  return model.nodes[n].name.empty() ? "node_" + std::to_string(n) : model.nodes[n].name;
}

struct Channel {
  int node;
  std::string path;  // translation, rotation, scale
  std::string interpolation;
  std::vector<double> times, values;  // values: components per key (x3 for CUBICSPLINE)
  int components;
};

// A channel's value at time t.
std::vector<double> sample(const Channel& c, double t) {
  const size_t n = c.times.size();
  const int k = c.components;
  const bool cubic = c.interpolation == "CUBICSPLINE";
  const auto key = [&](size_t i) {
    const size_t at = cubic ? (3 * i + 1) * k : i * k;  // the value between the tangents
    return std::vector<double>(c.values.begin() + at, c.values.begin() + at + k);
  };
  if (t <= c.times.front()) return key(0);
  if (t >= c.times.back()) return key(n - 1);
  const size_t i = std::upper_bound(c.times.begin(), c.times.end(), t) - c.times.begin() - 1;
  const double span = c.times[i + 1] - c.times[i];
  const double u = span > 0 ? (t - c.times[i]) / span : 0.0;
  if (c.interpolation == "STEP" || u <= 0) return key(i);
  auto a = key(i), b = key(i + 1);
  if (c.path == "rotation") {
    const Eigen::Quaterniond qa(a[3], a[0], a[1], a[2]), qb(b[3], b[0], b[1], b[2]);
    const auto q = qa.normalized().slerp(u, qb.normalized());
    return {q.x(), q.y(), q.z(), q.w()};
  }
  for (int j = 0; j < k; ++j) a[j] += u * (b[j] - a[j]);
  return a;
}

void apply(Trs& trs, const Channel& c, const std::vector<double>& v) {
  // An animated node with a matrix has no TRS to animate (glTF forbids it).
  if (c.path == "translation") trs.translation = {v[0], v[1], v[2]};
  if (c.path == "rotation") trs.rotation = Eigen::Quaterniond(v[3], v[0], v[1], v[2]);
  if (c.path == "scale") trs.scale = {v[0], v[1], v[2]};
}

}  // namespace

ImportedCharacter import_gltf(const std::string& path, const GltfImportOptions& options) {
  const tinygltf::Model model = gltf::load(path);
  ImportedCharacter out;
  const int num_nodes = static_cast<int>(model.nodes.size());
  std::vector<int> parent(num_nodes, -1);
  for (int n = 0; n < num_nodes; ++n)
    for (int child : model.nodes[n].children) {
      FSKIN_CHECK(child >= 0 && child < num_nodes && parent[child] < 0,
                  "{}: node {} has an invalid or second parent", path, child);
      parent[child] = n;
    }

  // The skin of the first skinned mesh node; meshes with other skins are dropped.
  std::vector<int> skinned;
  int skin_index = -1;
  for (int n = 0; n < num_nodes; ++n) {
    const auto& node = model.nodes[n];
    if (node.mesh < 0) continue;
    if (node.skin < 0) {
      out.notes.push_back(fmt::format("dropped mesh node '{}': it has no skin", node_name(model, n)));
      continue;
    }
    if (skin_index < 0) skin_index = node.skin;
    if (node.skin != skin_index) {
      out.notes.push_back(fmt::format("dropped mesh node '{}': skinned by skin {}, not skin {}", node_name(model, n),
                                      node.skin, skin_index));
      continue;
    }
    skinned.push_back(n);
  }
  FSKIN_CHECK(skin_index >= 0 && skin_index < static_cast<int>(model.skins.size()),
              "{}: no skinned mesh (no node has both a mesh and a skin): fskin needs a rigged character", path);
  const auto& skin = model.skins[skin_index];
  const auto J = static_cast<int64_t>(skin.joints.size());
  FSKIN_CHECK(J >= 1, "{}: skin {} has no joints", path, skin_index);

  // Joint tree: a joint's parent is its nearest ancestor node that is a joint.
  std::map<int, int> slot_of;  // node -> index in skin.joints
  for (int64_t i = 0; i < J; ++i) slot_of[skin.joints[i]] = static_cast<int>(i);
  std::vector<int> joint_parent(J, -1);
  std::vector<std::string> roots;
  for (int64_t i = 0; i < J; ++i) {
    for (int a = parent[skin.joints[i]]; a >= 0; a = parent[a])
      if (slot_of.count(a)) {
        joint_parent[i] = slot_of[a];
        break;
      }
    if (joint_parent[i] < 0) roots.push_back(node_name(model, skin.joints[i]));
  }
  FSKIN_CHECK(roots.size() == 1, "{}: the skeleton has {} roots ({}{}); fskin needs one root joint", path,
              roots.size(), fmt::format("{}", fmt::join(roots.begin(), roots.begin() + std::min<size_t>(roots.size(), 5), ", ")),
              roots.size() > 5 ? ", ..." : "");
  // Parents first, otherwise in the skin's order: a slot is taken once its
  // parent has been (the skin's own order when it already is topological).
  std::vector<int> order;  // fskin index -> skin slot
  std::vector<int64_t> fskin_index(J, -1);
  while (static_cast<int64_t>(order.size()) < J) {
    for (int64_t i = 0; i < J; ++i)
      if (fskin_index[i] < 0 && (joint_parent[i] < 0 || fskin_index[joint_parent[i]] >= 0)) {
        fskin_index[i] = static_cast<int64_t>(order.size());
        order.push_back(static_cast<int>(i));
      }
  }
  auto& data = out.model;
  for (int64_t j = 0; j < J; ++j) {
    const int slot = order[j];
    data.joint_names.push_back(node_name(model, skin.joints[slot]));
    data.parents.push_back(joint_parent[slot] < 0 ? -1 : fskin_index[joint_parent[slot]]);
  }
  {
    std::set<std::string> unique(data.joint_names.begin(), data.joint_names.end());
    FSKIN_CHECK(unique.size() == data.joint_names.size(), "{}: two joints share a name; fskin needs unique names", path);
  }

  // Inverse bind matrices (identity when absent, glTF's default) and rest joints.
  std::vector<Matrix4> inverse_bind(J, Matrix4::Identity());
  if (skin.inverseBindMatrices >= 0) {
    const auto m = gltf::read_accessor(model, skin.inverseBindMatrices, TINYGLTF_TYPE_MAT4, path, "inverseBindMatrices");
    FSKIN_CHECK(static_cast<int64_t>(m.size()) == 16 * J, "{}: {} inverse bind matrices for {} joints", path,
                m.size() / 16, J);
    for (int64_t i = 0; i < J; ++i)
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) inverse_bind[i](r, c) = m[16 * i + 4 * c + r];
  }
  data.rest_joints = torch::zeros({J, 3});
  for (int64_t j = 0; j < J; ++j) {
    const Matrix4 bind = inverse_bind[order[j]].inverse();
    FSKIN_CHECK(bind.allFinite(), "{}: the inverse bind matrix of joint '{}' is singular", path, data.joint_names[j]);
    for (int a = 0; a < 3; ++a) data.rest_joints[j][a] = bind(a, 3);
  }

  // Mesh: merge the skinned triangle primitives, weld vertices by position.
  std::vector<double> positions, weights;  // [V * 3], [V * J]
  std::vector<int64_t> faces;
  int64_t merged = 0;
  for (int n : skinned) {
    const auto& mesh = model.meshes[model.nodes[n].mesh];
    for (const auto& primitive : mesh.primitives) {
      const std::string what = fmt::format("mesh '{}'", mesh.name.empty() ? node_name(model, n) : mesh.name);
      if (primitive.mode != -1 && primitive.mode != TINYGLTF_MODE_TRIANGLES) {
        out.notes.push_back(fmt::format("dropped a non-triangle primitive (mode {}) of {}", primitive.mode, what));
        continue;
      }
      const auto attribute = [&](const char* name) {
        const auto it = primitive.attributes.find(name);
        return it == primitive.attributes.end() ? -1 : it->second;
      };
      FSKIN_CHECK(attribute("POSITION") >= 0, "{}: {} has a primitive without POSITION", path, what);
      if (attribute("JOINTS_0") < 0 || attribute("WEIGHTS_0") < 0) {
        out.notes.push_back(fmt::format("dropped a primitive of {} without JOINTS_0/WEIGHTS_0", what));
        continue;
      }
      const auto p = gltf::read_accessor(model, attribute("POSITION"), TINYGLTF_TYPE_VEC3, path, what + " POSITION");
      const int64_t base = static_cast<int64_t>(positions.size() / 3), count = static_cast<int64_t>(p.size() / 3);
      positions.insert(positions.end(), p.begin(), p.end());
      weights.resize(weights.size() + count * J, 0.0);
      for (int set = 0; set < 2; ++set) {
        const int ja = attribute(set == 0 ? "JOINTS_0" : "JOINTS_1"), wa = attribute(set == 0 ? "WEIGHTS_0" : "WEIGHTS_1");
        if (ja < 0 || wa < 0) continue;
        const auto ids = gltf::read_accessor(model, ja, TINYGLTF_TYPE_VEC4, path, what + " JOINTS");
        const auto ws = gltf::read_accessor(model, wa, TINYGLTF_TYPE_VEC4, path, what + " WEIGHTS");
        FSKIN_CHECK(ids.size() == 4 * static_cast<size_t>(count) && ws.size() == ids.size(),
                    "{}: {} has {} joint entries and {} weights for {} vertices", path, what, ids.size(), ws.size(), count);
        for (int64_t v = 0; v < count; ++v)
          for (int k = 0; k < 4; ++k) {
            const double w = ws[4 * v + k];
            if (w == 0) continue;
            const auto slot = static_cast<int64_t>(ids[4 * v + k]);
            FSKIN_CHECK(slot >= 0 && slot < J, "{}: {} vertex {} refers to joint {} of a {}-joint skin", path, what, v,
                        slot, J);
            FSKIN_CHECK(w > 0 && std::isfinite(w), "{}: {} vertex {} has weight {}", path, what, v, w);
            weights[(base + v) * J + fskin_index[slot]] += w;
          }
      }
      if (primitive.indices >= 0) {
        const auto idx = gltf::read_accessor(model, primitive.indices, TINYGLTF_TYPE_SCALAR, path, what + " indices");
        FSKIN_CHECK(idx.size() % 3 == 0, "{}: {} has {} indices, not a multiple of 3", path, what, idx.size());
        for (double i : idx) {
          FSKIN_CHECK(i >= 0 && i < count, "{}: {} index {} out of range for {} vertices", path, what, i, count);
          faces.push_back(base + static_cast<int64_t>(i));
        }
      } else {
        for (int64_t i = 0; i < count; ++i) faces.push_back(base + i);
      }
      ++merged;
    }
  }
  FSKIN_CHECK(merged > 0 && !faces.empty(), "{}: the skinned meshes have no skinned triangles", path);
  const int64_t V_in = static_cast<int64_t>(positions.size() / 3);
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
  for (size_t f = 0; f < faces.size(); f += 3) {
    const int64_t a = remap[faces[f]], b = remap[faces[f + 1]], c = remap[faces[f + 2]];
    if (a == b || b == c || a == c) {
      ++degenerate;
      continue;
    }
    welded_faces.insert(welded_faces.end(), {a, b, c});
  }
  out.notes.push_back(fmt::format("merged {} skinned primitive(s): {} vertices welded to {} by position{}", merged, V_in,
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
              "non-manifold edges); fskin learns occupancy and needs a closed surface",
              path, components.count);
  if (dropped > 0)
    out.notes.push_back(fmt::format("dropped {} of {} connected parts that are not closed surfaces", dropped, components.count));
  out.notes.push_back(options.keep_open_parts
                          ? fmt::format("kept all {} part(s), closed or not", kept_faces.size())
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

  // Clips: skinning matrices S_j(t) = P_j(t) IBM_j at the keyframe times.
  std::vector<Trs> rest(num_nodes);
  for (int n = 0; n < num_nodes; ++n) rest[n] = rest_trs(model.nodes[n]);
  for (size_t a = 0; a < model.animations.size(); ++a) {
    const auto& animation = model.animations[a];
    const std::string name = animation.name.empty() ? "clip_" + std::to_string(a) : animation.name;
    std::vector<Channel> channels;
    std::set<double> time_set;
    for (const auto& ch : animation.channels) {
      if (ch.target_node < 0 || ch.target_path == "weights") continue;
      FSKIN_CHECK(ch.sampler >= 0 && ch.sampler < static_cast<int>(animation.samplers.size()),
                  "{}: animation '{}' has a channel without a sampler", path, name);
      const auto& sampler = animation.samplers[ch.sampler];
      Channel c;
      c.node = ch.target_node;
      c.path = ch.target_path;
      c.interpolation = sampler.interpolation.empty() ? "LINEAR" : sampler.interpolation;
      c.components = c.path == "rotation" ? 4 : 3;
      c.times = gltf::read_accessor(model, sampler.input, TINYGLTF_TYPE_SCALAR, path, "animation '" + name + "' input");
      c.values = gltf::read_accessor(model, sampler.output, c.components == 4 ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3,
                                     path, "animation '" + name + "' output");
      const size_t per_key = (c.interpolation == "CUBICSPLINE" ? 3 : 1) * c.components;
      FSKIN_CHECK(!c.times.empty() && c.values.size() == per_key * c.times.size(),
                  "{}: animation '{}' has {} keyframe times and {} values", path, name, c.times.size(), c.values.size());
      time_set.insert(c.times.begin(), c.times.end());
      channels.push_back(std::move(c));
    }
    if (channels.empty()) continue;
    std::vector<double> times(time_set.begin(), time_set.end());
    const auto T = static_cast<int64_t>(times.size());
    auto bones = torch::zeros({T, J, 4, 4}, torch::kFloat64);
    auto bones_a = bones.accessor<double, 4>();
    for (int64_t t = 0; t < T; ++t) {
      auto locals = rest;
      for (const auto& c : channels) apply(locals[c.node], c, sample(c, times[t]));
      const auto global = global_transforms(locals, parent);
      for (int64_t j = 0; j < J; ++j) {
        const int slot = order[j];
        const Matrix4 s = global[skin.joints[slot]] * inverse_bind[slot];
        for (int r = 0; r < 4; ++r)
          for (int c = 0; c < 4; ++c) bones_a[t][j][r][c] = s(r, c);
      }
    }
    const auto pose = pose_from_bone_transforms(data.parents, data.rest_joints, bones);
    ImportedClip clip;
    clip.name = name;
    clip.poses.poses = pose.local_rotations;
    clip.poses.trans = pose.root_translation;
    clip.poses.joint_names = data.joint_names;
    clip.max_joint_drift = pose.max_joint_drift;
    if (T > 1) {
      std::vector<double> steps;
      for (int64_t t = 1; t < T; ++t) steps.push_back(times[t] - times[t - 1]);
      std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
      if (steps[steps.size() / 2] > 0) clip.fps = 1.0 / steps[steps.size() / 2];
    }
    const double size = character_size(data.v_template);
    if (pose.max_joint_drift > 1e-4 * size)
      out.notes.push_back(fmt::format("clip '{}' animates translations or scales of non-root joints: kept as rotations, "
                                      "which moves joints by up to {:.4g} m ({:.2g} % of the character's size)",
                                      name, pose.max_joint_drift, 100 * pose.max_joint_drift / size));
    out.clips.push_back(std::move(clip));
  }
  BodyModel(data, path);  // validates
  return out;
}

PoseSet concatenate_clips(const std::vector<ImportedClip>& clips) {
  FSKIN_CHECK(!clips.empty(), "concatenate_clips: no clips");
  PoseSet set;
  std::vector<torch::Tensor> poses, trans;
  int64_t start = 0;
  for (const auto& c : clips) {
    poses.push_back(c.poses.poses);
    trans.push_back(c.poses.trans);
    set.clip_names.push_back(c.name);
    set.clip_starts.push_back(start);
    start += c.poses.size();
  }
  set.poses = torch::cat(poses);
  set.trans = torch::cat(trans);
  set.joint_names = clips.front().poses.joint_names;
  return set;
}

}  // namespace fskin
