#pragma once
// One frame of an fskin dataset: a posed mesh, its query points with
// ground-truth occupancy, and the bone transforms that posed it. Stored as one
// .npz file per frame:
//   points               (N, 3)    float32  the first num_uniform are uniform in the
//                                           box (IoU_bbox set), the rest near the
//                                           surface (IoU_surf set)
//   occupancy            (N,)      uint8    1 = inside the posed mesh
//   num_uniform          (1,)      int64
//   bone_transforms      (J, 4, 4) float32  canonical -> posed (docs/conventions.md)
//   bone_transforms_rest (J, 4, 4) float32  rest pose -> posed
//   pose                 (J, 3)    float32  axis-angle
//   trans                (3,)      float32  root translation
//   box                  (2, 3)    float32  min / max corner of the uniform samples' box
//   vertices             (V, 3)    float32  the posed mesh (optional)
//   faces                (F, 3)    int64    (with vertices)
//   joints               (J, 3)    float32  joint positions (canonical.npz only:
//                                           the skeleton the bootstrap losses need)
#include <torch/types.h>

#include <string>

namespace fskin {

struct DatasetFrame {
  torch::Tensor points, occupancy;
  int64_t num_uniform = 0;
  torch::Tensor bone_transforms, bone_transforms_rest, pose, trans, box;
  torch::Tensor vertices, faces;  // undefined when loaded without the mesh or when
                                  // the frame has none (the 2D stick set)
  torch::Tensor joints;           // undefined except in canonical.npz

  int64_t num_points() const { return points.defined() ? points.size(0) : 0; }
  // The uniform (IoU_bbox) and near-surface (IoU_surf) halves.
  torch::Tensor uniform_points() const { return points.slice(0, 0, num_uniform); }
  torch::Tensor uniform_occupancy() const { return occupancy.slice(0, 0, num_uniform); }
  torch::Tensor surface_points() const { return points.slice(0, num_uniform); }
  torch::Tensor surface_occupancy() const { return occupancy.slice(0, num_uniform); }

  // Atomic and deterministic (same content -> same bytes).
  void save(const std::string& path) const;
  // Throws fskin::Error naming `path` on missing arrays or inconsistent shapes.
  static DatasetFrame load(const std::string& path, bool with_mesh = true);
  void validate(const std::string& context) const;
};

}  // namespace fskin
