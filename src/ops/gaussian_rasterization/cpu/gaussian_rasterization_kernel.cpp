// CPU kernel of the Gaussian rasterisation: at::parallel_for over 16 x 16
// tiles, a tile's pixels in row order on one thread. Each tile first packs
// its entries' means, conics, opacities and colours into contiguous arrays in
// list order, so that its 256 pixels stream through them instead of
// gathering from the whole scene for every pixel. The backward writes each
// pixel's gradients into its tile entry's row, which no other tile touches,
// so no locks or atomics are needed and the sums do not depend on scheduling.
#include <ATen/Parallel.h>

#include <algorithm>
#include <numeric>
#include <vector>

#include "ops/gaussian_rasterization/gaussian_rasterization_kernel.h"

namespace fskin::gaussian_rasterization {
namespace {

// A tile's entries [begin, end) as a launch of their own (Gaussian i of the
// packed arrays is entry begin + i); the outputs stay the global ones.
template <typename T>
struct PackedTile {
  std::vector<T> means2d, conics, colors, opacities;
  std::vector<int64_t> order;
  RasterLaunch<T> launch;

  void pack(const RasterLaunch<T>& a, int64_t begin, int64_t end) {
    const int64_t k = end - begin;
    const int c = a.channels;
    means2d.resize(2 * k);
    conics.resize(3 * k);
    colors.resize(c * k);
    opacities.resize(k);
    order.resize(k);
    std::iota(order.begin(), order.end(), int64_t{0});
    for (int64_t i = 0; i < k; ++i) {
      const int64_t g = a.tile_gaussians[begin + i];
      std::copy_n(a.means2d + 2 * g, 2, means2d.data() + 2 * i);
      std::copy_n(a.conics + 3 * g, 3, conics.data() + 3 * i);
      std::copy_n(a.colors + c * g, c, colors.data() + c * i);
      opacities[i] = a.opacities[g];
    }
    launch = a;
    launch.means2d = means2d.data();
    launch.conics = conics.data();
    launch.colors = colors.data();
    launch.opacities = opacities.data();
    launch.tile_gaussians = order.data();
  }
};

}  // namespace

template <typename T>
void rasterize_cpu(const RasterLaunch<T>& a, bool backward) {
  const int64_t tiles = static_cast<int64_t>(a.tiles_x) * a.tiles_y;
  const int columns = gradient_columns(a.channels);
  at::parallel_for(0, tiles, 1, [&](int64_t first_tile, int64_t last_tile) {
    PackedTile<T> packed;
    for (int64_t tile = first_tile; tile < last_tile; ++tile) {
      const int64_t begin = a.tile_ranges[tile], end = a.tile_ranges[tile + 1];
      const int x0 = static_cast<int>(tile % a.tiles_x) * kTileSize;
      const int y0 = static_cast<int>(tile / a.tiles_x) * kTileSize;
      const int x1 = std::min(x0 + kTileSize, a.width), y1 = std::min(y0 + kTileSize, a.height);
      packed.pack(a, begin, end);
      const RasterLaunch<T>& local = packed.launch;
      const int64_t count = end - begin;
      for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) {
          if (backward) {
            rasterize_pixel_backward(local, 0, count, x, y, [&](int64_t entry, int64_t, int column, T value) {
              a.grad_rows[(begin + entry) * columns + column] += value;
            });
          } else {
            rasterize_pixel(local, 0, count, x, y);
          }
        }
      }
    }
  });
}

template void rasterize_cpu<float>(const RasterLaunch<float>&, bool);
template void rasterize_cpu<double>(const RasterLaunch<double>&, bool);

}  // namespace fskin::gaussian_rasterization
