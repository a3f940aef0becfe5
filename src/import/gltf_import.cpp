#include "fskin/import/gltf_import.h"

#include <torch/torch.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "fskin/core/error.h"
#include "import/rig_assembly.h"
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

// Global transforms of every node from local ones, visiting nodes in
// `parents_first` order (a loop, not a recursion: a node chain may be as deep
// as the file has nodes).
std::vector<Matrix4> global_transforms(const std::vector<Trs>& locals, const std::vector<int>& parent,
                                       const std::vector<int>& parents_first) {
  std::vector<Matrix4> global(locals.size());
  for (int n : parents_first)
    global[n] = parent[n] < 0 ? locals[n].to_matrix() : Matrix4(global[parent[n]] * locals[n].to_matrix());
  return global;
}

// The nodes in breadth-first order from the roots; throws if a node is not
// reached (it lies on a cycle). Linear in the number of nodes.
std::vector<int> nodes_parents_first(const tinygltf::Model& model, const std::vector<int>& parent,
                                     const std::string& path) {
  const int num_nodes = static_cast<int>(parent.size());
  std::vector<int> order;
  order.reserve(num_nodes);
  for (int n = 0; n < num_nodes; ++n)
    if (parent[n] < 0) order.push_back(n);
  for (size_t i = 0; i < order.size(); ++i)
    for (int child : model.nodes[order[i]].children) order.push_back(child);
  if (static_cast<int>(order.size()) < num_nodes) {
    std::vector<char> reached(num_nodes, 0);
    for (int n : order) reached[n] = 1;
    const int first = static_cast<int>(std::find(reached.begin(), reached.end(), 0) - reached.begin());
    fail("{}: the node tree has a cycle through node {}", path, first);
  }
  return order;
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

// glTF 2.0 sec. 3.11: key times strictly increase; rotations are unit
// quaternions.
void check_keyframes(const Channel& c, const std::string& path, const std::string& clip, const std::string& node) {
  for (size_t i = 0; i < c.times.size(); ++i) {
    FSKIN_CHECK(std::isfinite(c.times[i]), "{}: animation '{}' ({} {}) has key time {}", path, clip, node, c.path,
                c.times[i]);
    FSKIN_CHECK(i == 0 || c.times[i] > c.times[i - 1],
                "{}: animation '{}' ({} {}) has key times that do not increase ({} after {})", path, clip, node,
                c.path, c.times[i], c.times[i - 1]);
  }
  for (size_t i = 0; i < c.values.size(); ++i)
    FSKIN_CHECK(std::isfinite(c.values[i]), "{}: animation '{}' ({} {}) has value {}", path, clip, node, c.path,
                c.values[i]);
  if (c.path != "rotation") return;
  const bool cubic = c.interpolation == "CUBICSPLINE";
  for (size_t k = 0; k < c.times.size(); ++k) {
    const size_t at = (cubic ? 3 * k + 1 : k) * 4;  // glTF: (x, y, z, w)
    import_detail::check_key_rotation(c.values[at + 3], c.values[at], c.values[at + 1], c.values[at + 2], path,
                                      fmt::format("animation '{}' ({} rotation at {} s)", clip, node, c.times[k]));
  }
}

void apply(Trs& trs, const Channel& c, const std::vector<double>& v) {
  // An animated node with a matrix has no TRS to animate (glTF forbids it).
  if (c.path == "translation") trs.translation = {v[0], v[1], v[2]};
  if (c.path == "rotation") trs.rotation = Eigen::Quaterniond(v[3], v[0], v[1], v[2]);
  if (c.path == "scale") trs.scale = {v[0], v[1], v[2]};
}

}  // namespace

ImportedCharacter import_gltf(const std::string& path, const ImportOptions& options) {
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
  for (int n = 0; n < num_nodes; ++n) {
    const auto& node = model.nodes[n];
    FSKIN_CHECK(node.mesh >= -1 && node.mesh < static_cast<int>(model.meshes.size()),
                "{}: node {} refers to mesh {} of {}", path, n, node.mesh, model.meshes.size());
    FSKIN_CHECK(node.skin >= -1 && node.skin < static_cast<int>(model.skins.size()),
                "{}: node {} refers to skin {} of {}", path, n, node.skin, model.skins.size());
  }
  const auto parents_first = nodes_parents_first(model, parent, path);

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
  import_detail::SourceJoints joints;
  std::map<int, int> slot_of;  // node -> index in skin.joints
  for (int64_t i = 0; i < J; ++i) {
    const int node = skin.joints[i];
    FSKIN_CHECK(node >= 0 && node < num_nodes, "{}: skin {} refers to node {} of {}", path, skin_index, node, num_nodes);
    slot_of[node] = static_cast<int>(i);
  }
  // Each node's nearest joint ancestor, parents first: linear in the nodes.
  std::vector<int> joint_above(num_nodes, -1);
  for (int n : parents_first) {
    const int a = parent[n];
    if (a < 0) continue;
    const auto it = slot_of.find(a);
    joint_above[n] = it != slot_of.end() ? it->second : joint_above[a];
  }
  for (int64_t i = 0; i < J; ++i) {
    joints.names.push_back(node_name(model, skin.joints[i]));
    joints.parent.push_back(joint_above[skin.joints[i]]);
  }
  // Inverse bind matrices: identity when absent, glTF's default.
  joints.inverse_bind.assign(J, Matrix4::Identity());
  if (skin.inverseBindMatrices >= 0) {
    const auto m = gltf::read_accessor(model, skin.inverseBindMatrices, TINYGLTF_TYPE_MAT4, path, "inverseBindMatrices");
    FSKIN_CHECK(static_cast<int64_t>(m.size()) == 16 * J, "{}: {} inverse bind matrices for {} joints", path,
                m.size() / 16, J);
    for (int64_t i = 0; i < J; ++i)
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) joints.inverse_bind[i](r, c) = m[16 * i + 4 * c + r];
  }
  auto& data = out.model;
  const auto order = import_detail::order_joints(path, joints, data);

  // Mesh: the skinned triangle primitives.
  import_detail::SkinnedSoup soup;
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
      const int64_t base = static_cast<int64_t>(soup.positions.size() / 3), count = static_cast<int64_t>(p.size() / 3);
      soup.positions.insert(soup.positions.end(), p.begin(), p.end());
      soup.weights.resize(soup.weights.size() + count * J, 0.0);
      for (int set = 0;; ++set) {
        const int ja = attribute(("JOINTS_" + std::to_string(set)).c_str());
        const int wa = attribute(("WEIGHTS_" + std::to_string(set)).c_str());
        if (ja < 0 || wa < 0) break;
        const auto ids = gltf::read_accessor(model, ja, TINYGLTF_TYPE_VEC4, path, what + " JOINTS");
        const auto ws = gltf::read_accessor(model, wa, TINYGLTF_TYPE_VEC4, path, what + " WEIGHTS");
        FSKIN_CHECK(ids.size() == 4 * static_cast<size_t>(count) && ws.size() == ids.size(),
                    "{}: {} has {} joint entries and {} weights for {} vertices", path, what, ids.size(), ws.size(), count);
        for (int64_t v = 0; v < count; ++v)
          for (int k = 0; k < 4; ++k) {
            const double w = ws[4 * v + k];
            if (w == 0) continue;
            const double id = ids[4 * v + k];  // checked before the cast: a float NaN or 1e30 is no index
            FSKIN_CHECK(id >= 0 && id < static_cast<double>(J) && id == std::floor(id),
                        "{}: {} vertex {} refers to joint {} of a {}-joint skin", path, what, v, id, J);
            const auto slot = static_cast<int64_t>(id);
            FSKIN_CHECK(w > 0 && std::isfinite(w), "{}: {} vertex {} has weight {}", path, what, v, w);
            soup.weights[(base + v) * J + order.index_of_slot[slot]] += w;
          }
      }
      if (primitive.indices >= 0) {
        const auto idx = gltf::read_accessor(model, primitive.indices, TINYGLTF_TYPE_SCALAR, path, what + " indices");
        FSKIN_CHECK(idx.size() % 3 == 0, "{}: {} has {} indices, not a multiple of 3", path, what, idx.size());
        for (double i : idx) {
          FSKIN_CHECK(i >= 0 && i < count, "{}: {} index {} out of range for {} vertices", path, what, i, count);
          soup.faces.push_back(base + static_cast<int64_t>(i));
        }
      } else {  // non-indexed: every three vertices are a triangle
        FSKIN_CHECK(count % 3 == 0, "{}: {} has no indices and {} vertices, not a multiple of 3", path, what, count);
        for (int64_t i = 0; i < count; ++i) soup.faces.push_back(base + i);
      }
      ++soup.parts;
    }
  }
  import_detail::assemble_mesh(path, soup, options, data, out.notes);

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
      FSKIN_CHECK(ch.target_node < num_nodes, "{}: animation '{}' targets node {} of {}", path, name, ch.target_node,
                  num_nodes);
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
      check_keyframes(c, path, name, node_name(model, c.node));
      time_set.insert(c.times.begin(), c.times.end());
      channels.push_back(std::move(c));
    }
    if (channels.empty()) continue;
    const std::vector<double> times(time_set.begin(), time_set.end());
    import_detail::check_clip_sampling_cost(times.size(), num_nodes, path, name);
    const auto skinning_at = [&](size_t t) {
      auto locals = rest;
      for (const auto& c : channels) apply(locals[c.node], c, sample(c, times[t]));
      const auto global = global_transforms(locals, parent, parents_first);
      std::vector<Matrix4> skinning(J);
      for (int64_t j = 0; j < J; ++j) {
        const int slot = order.slot_of[j];
        skinning[j] = global[skin.joints[slot]] * joints.inverse_bind[slot];
      }
      return skinning;
    };
    out.clips.push_back(import_detail::make_clip(path, name, times, skinning_at, data, out.notes));
  }
  BodyModel(data, path);  // validates
  return out;
}

}  // namespace fskin
