#pragma once
// The parts of a skinned glTF 2.0 asset that do not depend on what is
// skinned, shared by the skinned mesh (fskin/export/skinned_gltf.h) and the
// Gaussian avatar (fskin/gaussians/gaussian_gltf.h): per-vertex influences,
// the joint nodes and their skin, and a pose set as an animation of them.
// The conventions (joint frames, inverse bind matrices, channels) are those
// documented in skinned_gltf.h. Internal to src.
#include <tiny_gltf.h>
#include <torch/types.h>

#include <string>

#include "fskin/data/pose_set.h"
#include "fskin/skeleton/skeleton.h"
#include "io/gltf_file.h"

namespace fskin::gltf {

// JOINTS_n / WEIGHTS_n attributes of `primitive` for weights [V, J]: the
// `influences` largest per vertex, renormalised (0: every joint), in sets
// of four, joint indices as uint16 (the caller checks J <= 65535).
void add_skin_influences(tinygltf::Model& model, BufferWriter& writer, tinygltf::Primitive& primitive,
                         const torch::Tensor& weights, int64_t influences);

// Joint nodes 0..J-1 in the skeleton's order (the model must have no nodes
// yet), the skin over them (its index is returned), then a node that draws
// mesh `mesh` with that skin, and the default scene holding the root joint
// and that node.
int add_skinned_node(tinygltf::Model& model, BufferWriter& writer, const Skeleton& skeleton, int mesh,
                     const std::string& name);

// `animation` (relative to the rest pose, validated by the caller) as a clip
// of the joint nodes 0..J-1, one LINEAR keyframe per pose at t = i / fps.
void add_joint_animation(tinygltf::Model& model, BufferWriter& writer, const Skeleton& skeleton,
                         const PoseSet& animation, double fps, const std::string& name);

}  // namespace fskin::gltf
