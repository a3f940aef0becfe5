#pragma once
// Meshes of a trained articulated model: the posed surface (posed occupancy
// logit 0, hard-max aggregation over the canonical correspondences, SNARF
// eq. 9) or the canonical one, extracted with MISE (geometry/mise.h).
//
// SNARF and Fast-SNARF define the shape only implicitly in posed space, so
// animating them means one MISE per pose: the per-frame meshing cost that
// Invertible Neural Skinning compares against (a canonical mesh re-posed once
// per frame).
//
// The box meshed: the canonical extent of the training data (the canonical
// mesh's vertices, CanonicalSkeleton::extent) pushed forward with the model's
// own skinning weights and the bones (LBS, SNARF eq. 4), joined with the
// posed joints, then padded on every side by `padding` times its longest
// side. It follows the pose without ground truth, and a learned surface more
// than the padding away from where the model's skinning sends the canonical
// extent would be cut by the box (the mesh is then open there).
#include <torch/types.h>

#include <cstdint>
#include <functional>

#include "fskin/data/point_sampling.h"
#include "fskin/geometry/mesh.h"
#include "fskin/geometry/mise.h"
#include "fskin/models/occupancy_model.h"
#include "fskin/data/canonical_skeleton.h"

namespace fskin {

struct PosedMeshingOptions {
  MiseOptions mise;  // iso 0 on logits, inside above (the defaults)
  // Model evaluations per vertex that move it onto the learned surface
  // (MiseOptions::refinement_steps, geometry/iso_refinement.h): without them a
  // learned, nearly binary occupancy meshes with terraces.
  int64_t surface_steps = 4;
  double padding = kCanonicalBoxPadding;
  bool largest_component = false;  // drop floaters: keep the component with the most faces
};

struct MeshingResult {
  Mesh mesh;
  MiseStats stats;
  Box box;              // requested box (before padding to whole voxels)
  double seconds = 0;   // box, MISE and clean-up
};

// The posed box described above; bones [J, 4, 4] canonical -> posed. The
// canonical box is canonical_bounds (data/canonical_skeleton.h).
Box posed_meshing_box(OccupancyModel& model, const CanonicalSkeleton& skeleton,
                      const torch::Tensor& bones, double padding);

// The posed surface for bones [J, 4, 4] (canonical -> posed) and pose [J, 3]
// (the pose condition). Puts the model in inference mode (frozen Fast-SNARF grid).
MeshingResult mesh_posed(OccupancyModel& model, const CanonicalSkeleton& skeleton,
                         const torch::Tensor& bones, const torch::Tensor& pose, const PosedMeshingOptions& options,
                         const MiseProgress& progress = {});

// The canonical surface, conditioned on `pose` [J, 3] (the canonical pose).
MeshingResult mesh_canonical(OccupancyModel& model, const CanonicalSkeleton& skeleton,
                             const torch::Tensor& pose, const PosedMeshingOptions& options,
                             const MiseProgress& progress = {});

// One mesh per pose, bones [N, J, 4, 4] and poses [N, J, 3], in order;
// `on_mesh(index, result)` receives each (to write it and let it go).
// Progress bar over the poses when `progress`.
void mesh_pose_sequence(OccupancyModel& model, const CanonicalSkeleton& skeleton,
                        const torch::Tensor& bones, const torch::Tensor& poses, const PosedMeshingOptions& options,
                        const std::function<void(int64_t, MeshingResult&&)>& on_mesh, bool progress);

// Re-posing (INS eq. 19): the vertices of one canonical mesh moved into every
// pose by model.repose, so all frames share faces, vertex colours and vertex
// correspondences. bones [N, J, 4, 4] -> vertices [N, V, 3] float32, computed
// `batch` poses at a time.
torch::Tensor repose_vertices(OccupancyModel& model, const Mesh& canonical, const torch::Tensor& bones,
                              int64_t batch, bool progress);

}  // namespace fskin
