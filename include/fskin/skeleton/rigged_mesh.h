#pragma once
// A mesh bound to a skeleton by linear-blend-skinning weights: fskin's one
// rig type. The image datasets' and avatar runs' canonical character
// (radiance/avatar_character.h), what the rigged glTF writer exports
// (export/skinned_gltf.h), and BodyModel::rig() (the body model's template
// with its weights and skeleton) are all a RiggedMesh. The SMPL-format body
// model (body/body_model.h) adds shape and pose blend shapes on top; the
// training code's CanonicalSkeleton (data/canonical_skeleton.h) adds what the
// deformers need of the canonical body (extent, bones inside it).
#include <torch/types.h>

#include <cstdint>
#include <string>

#include "fskin/geometry/mesh.h"
#include "fskin/skeleton/skeleton.h"

namespace fskin {

struct RiggedMesh {
  Mesh mesh;              // the bind (canonical) pose
  torch::Tensor weights;  // [V, J], >= 0, rows summing to 1
  Skeleton skeleton;      // names, parents and joints in the bind pose

  int64_t num_joints() const { return skeleton.num_joints(); }
  // Throws fskin::Error prefixed with `context` unless the mesh and the
  // skeleton are valid and the weights are [V, J], finite, >= 0 with rows
  // summing to 1 (within 1e-3).
  void validate(const std::string& context) const;
};

// The mesh's vertices [V, 3] float32 on the CPU posed by bones [J, 4, 4]
// (canonical -> posed) through its weights (linear blend skinning, SNARF eq. 4).
torch::Tensor posed_vertices(const RiggedMesh& rigged, const torch::Tensor& bones);

}  // namespace fskin
