#pragma once
// The format-independent half of importing a rigged character: whatever the
// file format (glTF through tinygltf, FBX / Collada / others through assimp),
// a reader collects joints with their inverse bind matrices, a triangle soup
// with per-vertex weights and, per clip, the skinning matrices at the
// keyframe times, all in world space (metres, +Y up); these functions turn
// them into a validated body model and pose sets, the same way for every
// format.
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "fskin/import/imported_character.h"

namespace fskin::import_detail {

// Joints in the reader's own order ("slots").
struct SourceJoints {
  std::vector<std::string> names;
  std::vector<int> parent;                  // slot of the parent joint, -1 for a root
  std::vector<Eigen::Matrix4d> inverse_bind;  // world -> joint at rest
};

// fskin's joint order: parents first, otherwise the source's order.
struct JointOrder {
  std::vector<int> slot_of;              // fskin index -> source slot
  std::vector<int64_t> index_of_slot;    // source slot -> fskin index
};

// Fills data.joint_names, parents and rest_joints (translations of the bind
// matrices). Throws for more than one root, duplicate names or a singular
// inverse bind matrix.
JointOrder order_joints(const std::string& path, const SourceJoints& joints, BodyModelData& data);

// Triangles with per-vertex weights over the fskin joint order.
struct SkinnedSoup {
  std::vector<double> positions;  // [V * 3], world
  std::vector<double> weights;    // [V * J]
  std::vector<int64_t> faces;     // [F * 3]
  int64_t parts = 0;              // primitives / meshes merged, for the report
};

// Welds vertices by position (1e-6 of the character's size), drops
// degenerate faces and, unless options.keep_open_parts, the connected parts
// that are not closed; renormalises the weights. Fills data.v_template,
// faces, weights and appends what it did to notes.
void assemble_mesh(const std::string& path, const SkinnedSoup& soup, const ImportOptions& options,
                   BodyModelData& data, std::vector<std::string>& notes);

// Key rotations must be quaternions of about unit length (sloppy exporters'
// near-unit ones are normalised when sampled; a zero or huge one has no
// direction). Throws naming `path` and `where` (clip, node, key time).
void check_key_rotation(double w, double x, double y, double z, const std::string& path, const std::string& where);

// Sampling a clip costs key times x nodes: a file asking for more than 2e8
// node transforms is refused rather than sampled for hours.
void check_clip_sampling_cost(size_t key_times, size_t nodes, const std::string& path, const std::string& clip);

// A clip from skinning matrices (fskin order, world, rest -> posed) at
// `times` (seconds): local rotations, root translation and, when
// the clip moves joints off their rest offsets by more than 1e-4 of the
// character's size, joint translations (pose_from_bones.h); fps from the
// median key spacing.
// skinning_at(t) gives the J skinning matrices at times[t].
using SkinningAt = std::function<std::vector<Eigen::Matrix4d>(size_t t)>;
ImportedClip make_clip(const std::string& path, const std::string& name, const std::vector<double>& times,
                       const SkinningAt& skinning_at, const BodyModelData& data, std::vector<std::string>& notes);

}  // namespace fskin::import_detail
