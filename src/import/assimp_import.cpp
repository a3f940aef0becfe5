#include "fskin/import/assimp_import.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <torch/torch.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include "fskin/core/error.h"
#include "fskin/geometry/character_size.h"
#include "import/assimp_sandbox.h"
#include "import/rig_assembly.h"

namespace fskin {
namespace {

using Matrix4 = Eigen::Matrix4d;

Matrix4 to_eigen(const aiMatrix4x4& m) {
  Matrix4 e;  // aiMatrix4x4 is row-major: a1..a4 is the first row
  e << m.a1, m.a2, m.a3, m.a4, m.b1, m.b2, m.b3, m.b4, m.c1, m.c2, m.c3, m.c4, m.d1, m.d2, m.d3, m.d4;
  return e;
}

std::string lower_extension(const std::string& path) {
  auto e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

std::optional<double> metadata_number(const aiScene* scene, const char* key) {
  const aiMetadata* meta = scene->mMetaData;
  if (!meta) return std::nullopt;
  for (unsigned i = 0; i < meta->mNumProperties; ++i) {
    if (std::string(meta->mKeys[i].C_Str()) != key) continue;
    const aiMetadataEntry& v = meta->mValues[i];
    switch (v.mType) {
      case AI_BOOL: return *static_cast<bool*>(v.mData) ? 1.0 : 0.0;
      case AI_INT32: return *static_cast<int32_t*>(v.mData);
      case AI_UINT64: return static_cast<double>(*static_cast<uint64_t*>(v.mData));
      case AI_FLOAT: return *static_cast<float*>(v.mData);
      case AI_DOUBLE: return *static_cast<double*>(v.mData);
      default: return std::nullopt;
    }
  }
  return std::nullopt;
}

// FBX declares its unit (centimetres per file unit) and axis system; assimp
// keeps both as scene metadata without applying them. The result maps file
// coordinates to metres with the file's up axis on +Y and its front on +Z.
Matrix4 fbx_to_metres_y_up(const std::string& path, const aiScene* scene, std::vector<std::string>& notes) {
  const auto axis = [&](const char* name, const char* sign_name, int fallback) {
    const double value = metadata_number(scene, name).value_or(fallback);
    FSKIN_CHECK(value == 0 || value == 1 || value == 2, "{}: the FBX axis system has {} = {} (0, 1 or 2 expected)",
                path, name, value);
    const int a = static_cast<int>(value);
    const double s = metadata_number(scene, sign_name).value_or(1.0) < 0 ? -1.0 : 1.0;
    return std::make_pair(a, s);
  };
  const auto [coord, coord_sign] = axis("CoordAxis", "CoordAxisSign", 0);
  const auto [up, up_sign] = axis("UpAxis", "UpAxisSign", 1);
  const auto [front, front_sign] = axis("FrontAxis", "FrontAxisSign", 2);
  FSKIN_CHECK(coord != up && up != front && coord != front,
              "{}: the FBX axis system names one axis twice (CoordAxis {}, UpAxis {}, FrontAxis {})", path, coord, up,
              front);
  Eigen::Matrix3d axes = Eigen::Matrix3d::Zero();
  axes(0, coord) = coord_sign;
  axes(1, up) = up_sign;
  axes(2, front) = front_sign;
  if (axes.determinant() < 0) {
    // A left-handed declaration: keep up and front, flip the side axis so the
    // result is a rotation (a mirror would turn every triangle inside out).
    axes.row(0) *= -1;
    notes.push_back("the FBX axis system is left-handed: its side axis was flipped to keep the character unmirrored");
  }
  const double cm_per_unit = metadata_number(scene, "UnitScaleFactor").value_or(1.0);
  FSKIN_CHECK(std::isfinite(cm_per_unit) && cm_per_unit > 0, "{}: the FBX UnitScaleFactor is {}", path, cm_per_unit);
  const double metres = cm_per_unit / 100.0;
  const char* names[] = {"X", "Y", "Z"};
  notes.push_back(fmt::format("FBX unit {:g} cm (scaled by {:g} to metres), up {}{}, front {}{}: turned to +Y up, +Z front",
                              cm_per_unit, metres, up_sign < 0 ? "-" : "+", names[up], front_sign < 0 ? "-" : "+",
                              names[front]));
  Matrix4 m = Matrix4::Identity();
  m.block<3, 3>(0, 0) = metres * axes;
  return m;
}

struct Node {
  const aiNode* node;
  int parent;
  std::string name;
};

// Nodes in depth-first pre-order (parents before children), with an explicit
// stack: a node chain may be as deep as the file has nodes.
std::vector<Node> collect(const aiNode* root) {
  std::vector<Node> out;
  std::vector<std::pair<const aiNode*, int>> stack{{root, -1}};
  while (!stack.empty()) {
    const auto [node, parent] = stack.back();
    stack.pop_back();
    const int self = static_cast<int>(out.size());
    out.push_back({node, parent, node->mName.length ? node->mName.C_Str() : "node_" + std::to_string(self)});
    for (unsigned c = node->mNumChildren; c-- > 0;) stack.push_back({node->mChildren[c], self});
  }
  return out;
}

// The last key at or before t, for keys[0].mTime < t < keys[n - 1].mTime
// (key times checked non-decreasing): a binary search, so sampling a clip
// costs its key times x log(keys), not key times x keys.
template <typename Key>
unsigned last_key_at_or_before(const Key* keys, unsigned n, double t) {
  const Key* after = std::upper_bound(keys, keys + n, t, [](double value, const Key& k) { return value < k.mTime; });
  return std::min(static_cast<unsigned>(after - keys), n - 1) - 1;
}

Eigen::Vector3d lerp_key(const aiVectorKey* keys, unsigned n, double t, const Eigen::Vector3d& fallback) {
  if (n == 0) return fallback;
  const auto v = [&](unsigned i) { return Eigen::Vector3d(keys[i].mValue.x, keys[i].mValue.y, keys[i].mValue.z); };
  if (t <= keys[0].mTime) return v(0);
  if (t >= keys[n - 1].mTime) return v(n - 1);
  const unsigned i = last_key_at_or_before(keys, n, t);
  const double span = keys[i + 1].mTime - keys[i].mTime;
  const double u = span > 0 ? (t - keys[i].mTime) / span : 0.0;
  return v(i) + u * (v(i + 1) - v(i));
}

Eigen::Quaterniond slerp_key(const aiQuatKey* keys, unsigned n, double t, const Eigen::Quaterniond& fallback) {
  if (n == 0) return fallback;
  const auto q = [&](unsigned i) {
    const auto& k = keys[i].mValue;
    return Eigen::Quaterniond(k.w, k.x, k.y, k.z).normalized();
  };
  if (t <= keys[0].mTime) return q(0);
  if (t >= keys[n - 1].mTime) return q(n - 1);
  const unsigned i = last_key_at_or_before(keys, n, t);
  const double span = keys[i + 1].mTime - keys[i].mTime;
  const double u = span > 0 ? (t - keys[i].mTime) / span : 0.0;
  return q(i).slerp(u, q(i + 1));
}

// Key times that never decrease, finite values, unit rotations.
void check_keys(const aiNodeAnim* ch, const std::string& path, const std::string& clip) {
  const std::string node = ch->mNodeName.C_Str();
  const auto check_times = [&](const auto* keys, unsigned n, const char* what) {
    for (unsigned k = 1; k < n; ++k)
      FSKIN_CHECK(keys[k].mTime >= keys[k - 1].mTime, "{}: clip '{}' ({} {} keys) has key times that decrease ({} after {})",
                  path, clip, node, what, keys[k].mTime, keys[k - 1].mTime);
  };
  check_times(ch->mPositionKeys, ch->mNumPositionKeys, "position");
  check_times(ch->mRotationKeys, ch->mNumRotationKeys, "rotation");
  check_times(ch->mScalingKeys, ch->mNumScalingKeys, "scaling");
  for (unsigned k = 0; k < ch->mNumPositionKeys; ++k) {
    const auto& v = ch->mPositionKeys[k].mValue;
    FSKIN_CHECK(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z),
                "{}: clip '{}' ({}) has a non-finite position key at tick {}", path, clip, node, ch->mPositionKeys[k].mTime);
  }
  for (unsigned k = 0; k < ch->mNumScalingKeys; ++k) {
    const auto& v = ch->mScalingKeys[k].mValue;
    FSKIN_CHECK(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z),
                "{}: clip '{}' ({}) has a non-finite scaling key at tick {}", path, clip, node, ch->mScalingKeys[k].mTime);
  }
  for (unsigned k = 0; k < ch->mNumRotationKeys; ++k) {
    const auto& q = ch->mRotationKeys[k].mValue;
    import_detail::check_key_rotation(q.w, q.x, q.y, q.z, path,
                                      fmt::format("clip '{}' ({} rotation at tick {})", clip, node,
                                                  ch->mRotationKeys[k].mTime));
  }
}

}  // namespace

ImportedCharacter import_with_assimp(const std::string& path, const ImportOptions& options) {
  FSKIN_CHECK(std::filesystem::exists(path), "{}: no such file", path);
  FSKIN_CHECK(std::filesystem::is_regular_file(path), "{}: not a regular file", path);
  // A file assimp crashes, loops or runs out of memory on is refused here,
  // in a child process, before this process reads it (assimp_sandbox.h).
  import_detail::probe_with_assimp(path, options);
  Assimp::Importer importer;
  import_detail::configure_assimp(importer);
  const aiScene* scene = importer.ReadFile(path, import_detail::assimp_read_flags());
  FSKIN_CHECK(scene && scene->mRootNode, "{}: cannot read it: {}", path, importer.GetErrorString());
  import_detail::check_assimp_scene(scene, path);
  ImportedCharacter out;

  const auto extension = lower_extension(path);
  Matrix4 to_world = Matrix4::Identity();
  if (extension == ".fbx") {
    to_world = fbx_to_metres_y_up(path, scene, out.notes);
  } else if (extension == ".dae") {
    out.notes.push_back("Collada: the file's <unit> and <up_axis> applied (metres, +Y up)");
  } else {
    out.notes.push_back(fmt::format("{} files declare no unit or axes: taken as metres with +Y up", extension));
  }

  const std::vector<Node> nodes = collect(scene->mRootNode);
  const int num_nodes = static_cast<int>(nodes.size());
  std::map<std::string, std::vector<int>> by_name;
  for (int n = 0; n < num_nodes; ++n) by_name[nodes[n].name].push_back(n);
  std::vector<Matrix4> rest_local(num_nodes), rest_global(num_nodes);
  for (int n = 0; n < num_nodes; ++n) {
    rest_local[n] = to_eigen(nodes[n].node->mTransformation);
    rest_global[n] = (nodes[n].parent < 0 ? to_world : rest_global[nodes[n].parent]) * rest_local[n];
  }
  const auto node_of_bone = [&](const std::string& bone, const std::string& mesh) {
    const auto it = by_name.find(bone);
    FSKIN_CHECK(it != by_name.end(), "{}: bone '{}' of mesh '{}' is not a node of the scene", path, bone, mesh);
    FSKIN_CHECK(it->second.size() == 1, "{}: bone '{}' of mesh '{}' names {} nodes; fskin needs unique bone names",
                path, bone, mesh, it->second.size());
    return it->second.front();
  };

  // Skinned triangle meshes and the nodes that place them.
  struct Instance {
    int node;
    const aiMesh* mesh;
    std::string name;
  };
  std::vector<Instance> instances;
  for (int n = 0; n < num_nodes; ++n)
    for (unsigned k = 0; k < nodes[n].node->mNumMeshes; ++k) {
      const aiMesh* mesh = scene->mMeshes[nodes[n].node->mMeshes[k]];
      const std::string name = mesh->mName.length ? mesh->mName.C_Str() : nodes[n].name;
      if (!(mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) {
        out.notes.push_back(fmt::format("dropped mesh '{}': it has no triangles (points or lines)", name));
      } else if (mesh->mNumBones == 0) {
        out.notes.push_back(fmt::format("dropped mesh '{}': it has no skin", name));
      } else {
        instances.push_back({n, mesh, name});
      }
    }
  FSKIN_CHECK(!instances.empty(), "{}: no skinned mesh (no mesh has bones): fskin needs a rigged character", path);

  // Bones and their bind matrices in world space: assimp's offset matrix maps
  // the mesh's space to the bone's at bind time, so world -> bone is
  // offset * G_mesh^-1.
  std::map<int, Matrix4> bone_bind;  // node -> inverse bind (world)
  std::vector<int> bone_order;       // the bones' nodes in the order the meshes list them
  double bind_mismatch = 0;
  for (const auto& inst : instances) {
    const Matrix4 mesh_to_world_inverse = rest_global[inst.node].inverse();
    for (unsigned b = 0; b < inst.mesh->mNumBones; ++b) {
      const aiBone* bone = inst.mesh->mBones[b];
      const int n = node_of_bone(bone->mName.C_Str(), inst.name);
      const Matrix4 inverse_bind = to_eigen(bone->mOffsetMatrix) * mesh_to_world_inverse;
      FSKIN_CHECK(inverse_bind.allFinite(), "{}: bone '{}' of mesh '{}' has a non-finite offset matrix", path,
                  nodes[n].name, inst.name);
      const auto [it, inserted] = bone_bind.emplace(n, inverse_bind);
      if (inserted) bone_order.push_back(n);
      if (!inserted) bind_mismatch = std::max(bind_mismatch, (it->second - inverse_bind).cwiseAbs().maxCoeff());
    }
  }
  if (bind_mismatch > 1e-5)
    out.notes.push_back(fmt::format("meshes bind a bone at different places (largest matrix difference {:.3g}); the "
                                    "first mesh's bind matrix is used",
                                    bind_mismatch));

  // Joints: the bones and every node between them and their lowest common
  // ancestor. Everything here is linear in the nodes (pre-order puts parents
  // before children; a chain may be as deep as the file has nodes).
  std::vector<int> bones_below(num_nodes, 0), depth(num_nodes, 0);
  for (const auto& [n, m] : bone_bind) bones_below[n] = 1;
  for (int n = num_nodes - 1; n > 0; --n) bones_below[nodes[n].parent] += bones_below[n];
  for (int n = 1; n < num_nodes; ++n) depth[n] = depth[nodes[n].parent] + 1;
  int top = 0;  // the deepest node above every bone
  for (int n = 0; n < num_nodes; ++n)
    if (bones_below[n] == static_cast<int>(bone_bind.size()) && depth[n] >= depth[top]) top = n;
  std::set<int> connecting;  // in pre-order
  std::vector<char> walked(num_nodes, 0);
  for (int n : bone_order)
    for (int a = n; a >= 0 && !walked[a]; a = nodes[a].parent) {
      walked[a] = 1;
      if (!bone_bind.count(a)) connecting.insert(a);
      if (a == top) break;
    }
  if (!connecting.empty())
    out.notes.push_back(fmt::format("{} node(s) without weights joined the skeleton to connect the bones (root '{}')",
                                    connecting.size(), nodes[top].name));
  // Slots: the bones in the file's order (order_joints keeps it where it is
  // parents-first), then the connecting nodes.
  std::vector<int> joint_nodes = bone_order;
  joint_nodes.insert(joint_nodes.end(), connecting.begin(), connecting.end());
  import_detail::SourceJoints joints;
  std::map<int, int> slot_of_node;
  for (int n : joint_nodes) slot_of_node[n] = static_cast<int>(slot_of_node.size());
  std::vector<int> joint_above(num_nodes, -1);  // each node's nearest joint ancestor
  for (int n = 1; n < num_nodes; ++n) {
    const int a = nodes[n].parent;
    const auto it = slot_of_node.find(a);
    joint_above[n] = it != slot_of_node.end() ? it->second : joint_above[a];
  }
  for (int n : joint_nodes) {
    joints.names.push_back(nodes[n].name);
    joints.parent.push_back(n == top ? -1 : joint_above[n]);
    const auto bound = bone_bind.find(n);
    joints.inverse_bind.push_back(bound != bone_bind.end() ? bound->second : Matrix4(rest_global[n].inverse()));
  }
  auto& data = out.model;
  const auto order = import_detail::order_joints(path, joints, data);
  const auto J = static_cast<int64_t>(joints.names.size());
  std::vector<int> joint_node(J);  // fskin index -> scene node
  for (const auto& [n, slot] : slot_of_node) joint_node[order.index_of_slot[slot]] = n;

  // Mesh: world positions, faces, weights.
  import_detail::SkinnedSoup soup;
  for (const auto& inst : instances) {
    const aiMesh* mesh = inst.mesh;
    const Matrix4& G = rest_global[inst.node];
    const int64_t base = static_cast<int64_t>(soup.positions.size() / 3);
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const auto& p = mesh->mVertices[v];
      const Eigen::Vector4d w = G * Eigen::Vector4d(p.x, p.y, p.z, 1.0);
      FSKIN_CHECK(w.allFinite(), "{}: mesh '{}' vertex {} is not finite", path, inst.name, v);
      soup.positions.insert(soup.positions.end(), {w[0], w[1], w[2]});
    }
    soup.weights.resize(soup.weights.size() + static_cast<size_t>(mesh->mNumVertices) * J, 0.0);
    for (unsigned b = 0; b < mesh->mNumBones; ++b) {
      const aiBone* bone = mesh->mBones[b];
      const int64_t j = order.index_of_slot[slot_of_node.at(node_of_bone(bone->mName.C_Str(), inst.name))];
      for (unsigned k = 0; k < bone->mNumWeights; ++k) {
        const auto& vw = bone->mWeights[k];
        FSKIN_CHECK(vw.mVertexId < mesh->mNumVertices, "{}: bone '{}' weights vertex {} of mesh '{}' ({} vertices)",
                    path, bone->mName.C_Str(), vw.mVertexId, inst.name, mesh->mNumVertices);
        FSKIN_CHECK(std::isfinite(vw.mWeight) && vw.mWeight >= 0, "{}: bone '{}' gives vertex {} of mesh '{}' weight {}",
                    path, bone->mName.C_Str(), vw.mVertexId, inst.name, vw.mWeight);
        soup.weights[(base + vw.mVertexId) * J + j] += vw.mWeight;
      }
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines of a mixed mesh
      for (int k = 0; k < 3; ++k) soup.faces.push_back(base + face.mIndices[k]);
    }
    ++soup.parts;
  }
  import_detail::assemble_mesh(path, soup, options, data, out.notes);

  // Clips: S_j(t) = G_j(t) IBM_j, G from the animated local transforms.
  std::vector<Eigen::Vector3d> rest_t(num_nodes), rest_s(num_nodes);
  std::vector<Eigen::Quaterniond> rest_r(num_nodes);
  for (int n = 0; n < num_nodes; ++n) {
    aiVector3D s, t;
    aiQuaternion r;
    nodes[n].node->mTransformation.Decompose(s, r, t);
    rest_t[n] = {t.x, t.y, t.z};
    rest_s[n] = {s.x, s.y, s.z};
    rest_r[n] = Eigen::Quaterniond(r.w, r.x, r.y, r.z);
  }
  for (unsigned a = 0; a < scene->mNumAnimations; ++a) {
    const aiAnimation* animation = scene->mAnimations[a];
    const std::string name = animation->mName.length ? animation->mName.C_Str() : "clip_" + std::to_string(a);
    const double ticks_per_second = animation->mTicksPerSecond > 0 ? animation->mTicksPerSecond : 25.0;
    std::map<int, const aiNodeAnim*> channel_of;
    std::set<double> tick_set;
    for (unsigned c = 0; c < animation->mNumChannels; ++c) {
      const aiNodeAnim* ch = animation->mChannels[c];
      const auto it = by_name.find(ch->mNodeName.C_Str());
      if (it == by_name.end()) {
        out.notes.push_back(fmt::format("clip '{}': channel of unknown node '{}' ignored", name, ch->mNodeName.C_Str()));
        continue;
      }
      channel_of[it->second.front()] = ch;
      for (unsigned k = 0; k < ch->mNumPositionKeys; ++k) tick_set.insert(ch->mPositionKeys[k].mTime);
      for (unsigned k = 0; k < ch->mNumRotationKeys; ++k) tick_set.insert(ch->mRotationKeys[k].mTime);
      for (unsigned k = 0; k < ch->mNumScalingKeys; ++k) tick_set.insert(ch->mScalingKeys[k].mTime);
    }
    if (tick_set.empty()) continue;
    for (double tick : tick_set)
      FSKIN_CHECK(std::isfinite(tick), "{}: clip '{}' has a key at time {}", path, name, tick);
    for (const auto& [n, ch] : channel_of) check_keys(ch, path, name);
    import_detail::check_clip_sampling_cost(tick_set.size(), num_nodes, path, name);
    std::vector<double> ticks(tick_set.begin(), tick_set.end()), times;
    for (double tick : ticks) times.push_back(tick / ticks_per_second);
    std::vector<Matrix4> global(num_nodes);
    const auto skinning_at = [&](size_t t) {
      for (int n = 0; n < num_nodes; ++n) {
        Matrix4 local = rest_local[n];
        const auto it = channel_of.find(n);
        if (it != channel_of.end()) {
          const aiNodeAnim* ch = it->second;
          local.setIdentity();
          local.block<3, 3>(0, 0) =
              slerp_key(ch->mRotationKeys, ch->mNumRotationKeys, ticks[t], rest_r[n]).toRotationMatrix() *
              lerp_key(ch->mScalingKeys, ch->mNumScalingKeys, ticks[t], rest_s[n]).asDiagonal();
          local.block<3, 1>(0, 3) = lerp_key(ch->mPositionKeys, ch->mNumPositionKeys, ticks[t], rest_t[n]);
        }
        global[n] = (nodes[n].parent < 0 ? to_world : global[nodes[n].parent]) * local;
      }
      std::vector<Matrix4> skinning(J);
      for (int64_t j = 0; j < J; ++j) skinning[j] = global[joint_node[j]] * joints.inverse_bind[order.slot_of[j]];
      return skinning;
    };
    out.clips.push_back(import_detail::make_clip(path, name, times, skinning_at, data, out.notes));
  }
  BodyModel(data, path);  // validates
  return out;
}

}  // namespace fskin
