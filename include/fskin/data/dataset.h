#pragma once
// Reads one split of a dataset built by build_dataset() into memory once and
// serves training batches from it without touching the files again.
#include <torch/types.h>

#include <string>
#include <vector>

#include "fskin/data/dataset_frame.h"
#include "fskin/data/random.h"

namespace fskin {

// Version 2 added the skeleton (manifest "parents", canonical.npz "joints").
inline constexpr int kDatasetFormatVersion = 2;

struct DatasetBatch {
  torch::Tensor points;           // [B, N, 3] float32, posed space
  torch::Tensor occupancy;        // [B, N] float32 (0 or 1), ready for BCE
  torch::Tensor bone_transforms;  // [B, J, 4, 4] canonical -> posed
  torch::Tensor pose;             // [B, J, 3]
  std::vector<int64_t> frames;    // the frame indices in the split
};

class Dataset {
 public:
  // Loads split `split` ("train", "val", "test_within", "test_ood") of the
  // dataset in `dir`; meshes are kept only when `with_meshes`. Throws
  // fskin::Error naming the directory when the manifest is missing, the build
  // incomplete or the split unknown.
  static Dataset load(const std::string& dir, const std::string& split, bool with_meshes = false);
  // Only the manifest's skeleton and the canonical frame (no split, size() 0):
  // what models need to be rebuilt.
  static Dataset load_canonical(const std::string& dir);

  int64_t size() const { return static_cast<int64_t>(frames_.size()); }
  const DatasetFrame& frame(int64_t index) const;
  const std::string& split() const { return split_; }
  const std::vector<std::string>& joint_names() const { return joint_names_; }
  const std::vector<int64_t>& parents() const { return parents_; }  // parents[0] == -1
  // The canonical pose's mesh, joints, bone transforms (rest -> canonical) and box.
  const DatasetFrame& canonical() const { return canonical_; }

  // `frames` distinct frames (with repetition only when the split is smaller),
  // each with `surface_points` points drawn from its near-surface half and
  // `uniform_points` from its uniform half (papers: 2000 + 250), with
  // replacement. Deterministic given the Rng state.
  DatasetBatch sample_batch(int64_t frames, int64_t surface_points, int64_t uniform_points,
                            Rng& rng) const;

 private:
  std::string split_;
  std::vector<std::string> joint_names_;
  std::vector<int64_t> parents_;
  std::vector<DatasetFrame> frames_;
  DatasetFrame canonical_;
};

}  // namespace fskin
