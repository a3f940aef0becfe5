// CPU kernel of the Gaussian rasterisation: at::parallel_for over 16 x 16
// tiles, a tile on one thread. A tile first packs its entries' means, conics,
// opacities and colours into contiguous arrays in list order. It then walks
// its list once, Gaussian by Gaussian, front to back, carrying every pixel's
// transmittance and colour (the backward: its prefix), and visits only the
// pixels of the box where the Gaussian can count (footprint_reach): most
// Gaussians of a tile's list touch a small part of it, which a pixel-by-pixel
// loop would test against every Gaussian. Each pixel still sees the Gaussians
// in the same order with the same per-step arithmetic as the per-pixel core
// (the CUDA kernel's), so the two agree to the last bit.
//
// The backward sums each entry's gradients over its pixels in row order into
// the entry's own row, which no other tile touches: no locks or atomics, and
// the sums do not depend on scheduling.
#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "ops/gaussian_rasterization/gaussian_rasterization_kernel.h"

namespace fskin::gaussian_rasterization {
namespace {

// A tile's entries [begin, end) as a launch of their own: Gaussian i of the
// packed arrays is entry begin + i, and the tile walks them by that index
// (the launch has no tile lists); the outputs stay the global ones.
template <typename T>
struct PackedTile {
  std::vector<T> means2d, conics, colors, opacities;
  RasterLaunch<T> launch;

  void pack(const RasterLaunch<T>& a, int64_t begin, int64_t end) {
    const int64_t k = end - begin;
    const int c = a.channels;
    means2d.resize(2 * k);
    conics.resize(3 * k);
    colors.resize(c * k);
    opacities.resize(k);
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
    launch.tile_gaussians = nullptr;
    launch.tile_ranges = nullptr;
  }
};

// A tile's pixel rectangle [x0, x1) x [y0, y1).
struct PixelBox {
  int x0, y0, x1, y1;
  bool empty() const { return x0 >= x1 || y0 >= y1; }
};

// The part of `tile` where Gaussian g of the packed launch can count.
template <typename T>
PixelBox reach_within(const RasterLaunch<T>& a, int64_t g, const PixelBox& tile) {
  T half_x, half_y;
  if (!footprint_reach(a, g, half_x, half_y)) return tile;
  if (half_x < T(0) || half_y < T(0)) return {0, 0, 0, 0};
  const T u = a.means2d[2 * g], v = a.means2d[2 * g + 1];
  // In floating point first: the bounds may lie far outside int's range.
  const auto low = [](T value, int lowest, int highest) {
    const T c = std::ceil(value);
    return c <= T(lowest) ? lowest : c >= T(highest) ? highest : static_cast<int>(c);
  };
  const auto high = [](T value, int lowest, int highest) {  // one past floor(value)
    const T f = std::floor(value) + T(1);
    return f <= T(lowest) ? lowest : f >= T(highest) ? highest : static_cast<int>(f);
  };
  if (!(u == u) || !(v == v)) return tile;
  return {low(u - half_x, tile.x0, tile.x1), low(v - half_y, tile.y0, tile.y1), high(u + half_x, tile.x0, tile.x1),
          high(v + half_y, tile.y0, tile.y1)};
}

// Per thread: the packed tile and its pixels' running state.
template <typename T>
struct TileScratch {
  PackedTile<T> packed;
  std::vector<T> transmittance, color, total, tail;
  std::vector<unsigned char> stopped;
  std::vector<T> row;
};

template <typename T>
void forward_tile(const RasterLaunch<T>& a, const PixelBox& box, int64_t count, TileScratch<T>& s) {
  const RasterLaunch<T>& local = s.packed.launch;
  const int w = box.x1 - box.x0, pixels = w * (box.y1 - box.y0), c = a.channels;
  s.transmittance.assign(pixels, T(1));
  s.color.assign(static_cast<size_t>(pixels) * c, T(0));
  s.stopped.assign(pixels, 0);
  int running = pixels;
  for (int64_t i = 0; i < count && running > 0; ++i) {
    const PixelBox r = reach_within(local, i, box);
    for (int y = r.y0; y < r.y1; ++y) {
      for (int x = r.x0; x < r.x1; ++x) {
        const int p = (y - box.y0) * w + (x - box.x0);
        if (s.stopped[p]) continue;
        if (!blend_step(local, i, footprint(local, i, T(x), T(y)), s.transmittance[p], &s.color[p * c])) {
          s.stopped[p] = 1;
          --running;
        }
      }
    }
  }
  for (int y = box.y0; y < box.y1; ++y) {
    for (int x = box.x0; x < box.x1; ++x) {
      const int p = (y - box.y0) * w + (x - box.x0);
      write_pixel(a, static_cast<int64_t>(y) * a.width + x, &s.color[p * c], s.transmittance[p]);
    }
  }
}

template <typename T>
void backward_tile(const RasterLaunch<T>& a, const PixelBox& box, int64_t begin, int64_t count, TileScratch<T>& s) {
  const RasterLaunch<T>& local = s.packed.launch;
  const int w = box.x1 - box.x0, pixels = w * (box.y1 - box.y0), c = a.channels;
  const int columns = gradient_columns(c);
  s.transmittance.assign(pixels, T(1));
  s.color.assign(static_cast<size_t>(pixels) * c, T(0));  // the prefixes
  s.total.resize(static_cast<size_t>(pixels) * c);
  s.tail.resize(pixels);
  s.stopped.assign(pixels, 0);
  s.row.resize(columns);
  for (int y = box.y0; y < box.y1; ++y) {
    for (int x = box.x0; x < box.x1; ++x) {
      const int p = (y - box.y0) * w + (x - box.x0);
      s.tail[p] = begin_pixel_backward(a, static_cast<int64_t>(y) * a.width + x, &s.total[p * c]);
    }
  }
  int running = pixels;
  for (int64_t i = 0; i < count && running > 0; ++i) {
    const PixelBox r = reach_within(local, i, box);
    if (r.empty()) continue;
    std::fill(s.row.begin(), s.row.end(), T(0));
    const auto add = [&](int column, T value) { s.row[column] += value; };
    for (int y = r.y0; y < r.y1; ++y) {
      for (int x = r.x0; x < r.x1; ++x) {
        const int p = (y - box.y0) * w + (x - box.x0);
        if (s.stopped[p]) continue;
        const bool going = backward_step(local, static_cast<int64_t>(y) * a.width + x, i,
                                         footprint(local, i, T(x), T(y)), &s.total[p * c], s.tail[p],
                                         s.transmittance[p], &s.color[p * c], add);
        if (!going) {
          s.stopped[p] = 1;
          --running;
        }
      }
    }
    std::copy(s.row.begin(), s.row.end(), a.grad_rows + (begin + i) * columns);
  }
}

}  // namespace

template <typename T>
void rasterize_cpu(const RasterLaunch<T>& a, bool backward) {
  const int64_t tiles = static_cast<int64_t>(a.tiles_x) * a.tiles_y;
  at::parallel_for(0, tiles, 1, [&](int64_t first_tile, int64_t last_tile) {
    TileScratch<T> scratch;
    for (int64_t tile = first_tile; tile < last_tile; ++tile) {
      const int64_t begin = a.tile_ranges[tile], end = a.tile_ranges[tile + 1];
      PixelBox box;
      box.x0 = static_cast<int>(tile % a.tiles_x) * kTileSize;
      box.y0 = static_cast<int>(tile / a.tiles_x) * kTileSize;
      box.x1 = std::min(box.x0 + kTileSize, a.width);
      box.y1 = std::min(box.y0 + kTileSize, a.height);
      scratch.packed.pack(a, begin, end);
      if (backward) {
        backward_tile(a, box, begin, end - begin, scratch);
      } else {
        forward_tile(a, box, end - begin, scratch);
      }
    }
  });
}

template void rasterize_cpu<float>(const RasterLaunch<float>&, bool);
template void rasterize_cpu<double>(const RasterLaunch<double>&, bool);

}  // namespace fskin::gaussian_rasterization
