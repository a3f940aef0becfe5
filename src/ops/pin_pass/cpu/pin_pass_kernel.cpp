// The 64-byte vectors never cross a call boundary (everything is inlined into
// run_blocks), so GCC's note that passing them would change the ABI is moot.
#pragma GCC diagnostic ignored "-Wpsabi"

#include <ATen/Parallel.h>

#include <algorithm>
#include <memory>

#include "ops/pin_pass/pin_pass_kernel.h"

namespace fskin::pin_pass {
namespace {

// 16 points per GCC vector: one AVX-512 register (two AVX2, four SSE ones).
constexpr int kLanes = 16;
using Lanes = float __attribute__((vector_size(kLanes * sizeof(float))));

// Blocks [begin, end) of kLanes points; a block never spans two frames. Cloned
// per instruction set (GCC function multi-versioning) so a portable build still
// runs the lane loops on the widest vectors the CPU has.
__attribute__((target_clones("avx512f", "avx2", "default"))) void run_blocks(const PinPassLaunch& a,
                                                                            int64_t begin, int64_t end) {
  auto scratch = std::make_unique<Scratch<Lanes>>();
  const int64_t blocks_per_frame = (a.count + kLanes - 1) / kLanes;
  for (int64_t block = begin; block < end; ++block) {
    const int64_t b = block / blocks_per_frame, first = (block % blocks_per_frame) * kLanes;
    const int lanes = static_cast<int>(std::min<int64_t>(kLanes, a.count - first));
    float* points = a.points + (b * a.count + first) * 3;
    Lanes x[3];
    // A partial block repeats its last point in the spare lanes.
    for (int l = 0; l < kLanes; ++l)
      for (int c = 0; c < 3; ++c) x[c][l] = points[std::min(l, lanes - 1) * 3 + c];
    pin_block(a.shape, a.params + b * a.frame_stride, a.inverse, x, *scratch);
    for (int l = 0; l < lanes; ++l)
      for (int c = 0; c < 3; ++c) points[l * 3 + c] = x[c][l];
  }
}

}  // namespace

void pin_pass_cpu(const PinPassLaunch& a) {
  const int64_t blocks = a.batch * ((a.count + kLanes - 1) / kLanes);
  at::parallel_for(0, blocks, 64, [&](int64_t begin, int64_t end) { run_blocks(a, begin, end); });
}

}  // namespace fskin::pin_pass
