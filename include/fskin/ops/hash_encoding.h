#pragma once
// Multi-resolution hash encoding (instant-NGP, Mueller et al. 2022; the
// canonical radiance field of Fast-SNARF sec. 7 / InstantAvatar): L levels of
// grids with N_l = floor(N_min * b^l) cells per axis; each level keeps F
// features at the (N_l + 1)^3 grid vertices in a table of 2^T rows, indexed
// directly while the level fits ("dense levels") and by the spatial hash
// (x * 1) xor (y * 2654435761) xor (z * 805459861) mod 2^T above; a point's
// features are the trilinear interpolation of its cell's 8 vertices, level by
// level, concatenated.
//
// One fused op with a CPU kernel (at::parallel_for) and a CUDA kernel sharing
// their per-point core (src/ops/hash_encoding/), differentiable in the table
// and the positions (no double backward). In PyTorch's dispatcher as
// fskin::hash_encoding(positions, table, base_resolution, per_level_scale)
// (L, F and T are the table's shape) with its backward
// fskin::_hash_encoding_backward; Python: torch.ops.fskin.hash_encoding.
#include <torch/types.h>

#include <cstdint>

namespace fskin {

struct HashEncodingOptions {
  int64_t levels = 16;              // L
  int64_t features_per_level = 2;   // F
  int64_t log2_table_size = 19;     // T: 2^T rows per level
  int64_t base_resolution = 16;     // N_min
  double per_level_scale = 1.5;     // b (instant-NGP: exp(ln(N_max / N_min) / (L - 1)))

  int64_t table_size() const { return int64_t{1} << log2_table_size; }
  int64_t output_dim() const { return levels * features_per_level; }
  int64_t resolution(int64_t level) const;  // N_l
  bool hashed(int64_t level) const;         // (N_l + 1)^3 > 2^T
  // Throws fskin::Error naming the bad field (levels 1..32, F 1..8, T 4..24, N_min >= 1, b >= 1).
  void validate() const;
  // `levels` levels from base_resolution to finest_resolution (instant-NGP's
  // b = exp(ln(N_max / N_min) / (L - 1)); one level: b = 1).
  static HashEncodingOptions spanning(int64_t levels, int64_t base_resolution, int64_t finest_resolution,
                                      int64_t log2_table_size, int64_t features_per_level = 2);
};

constexpr int64_t kMaxHashLevels = 32;

// positions [N, 3] in the unit cube (clamped to [0, 1]: outside it a
// coordinate has no gradient), table [L, 2^T, F], both float32 or both
// float64 on one device -> features [N, L * F] (level-major). Gradients reach
// the table and the positions.
torch::Tensor hash_encoding(const torch::Tensor& positions, const torch::Tensor& table,
                            const HashEncodingOptions& options);

// A table of small random features as instant-NGP initialises it: U(-1e-4, 1e-4).
torch::Tensor hash_encoding_table(const HashEncodingOptions& options, torch::TensorOptions tensor_options = {});

// The same encoding in LibTorch operations (gathers and products, autograd's
// own gradients): the reference the fused op is tested and benchmarked against.
torch::Tensor hash_encoding_reference(const torch::Tensor& positions, const torch::Tensor& table,
                                      const HashEncodingOptions& options);

}  // namespace fskin
