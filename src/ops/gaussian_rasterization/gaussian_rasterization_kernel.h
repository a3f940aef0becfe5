#pragma once
// Raw-pointer arguments of the Gaussian rasterisation launches and the
// per-pixel forward and backward that both devices run (cpu/, cuda/).
// Torch-free so nvcc compiles it.
//
// A pixel blends the Gaussians of its 16 x 16 tile front to back (the tile's
// list is sorted by depth), as 3DGS does (Kerbl et al. 2023, eq. 2-3):
//   alpha_i = min(0.99, o_i exp(-1/2 d_i^T Q_i d_i)),  d_i = pixel - mean_i,
//   colour = sum_i c_i alpha_i T_i + T_final background,  T_i = prod_{j<i} (1 - alpha_j),
// skipping a Gaussian whose alpha is under 1/255 and stopping before the one
// that would take T under 1e-4 (the thresholds of the reference rasteriser and
// gsplat, so that trained scenes look the same in either).
#include <cmath>
#include <cstdint>

#include "ops/common/host_device.h"

namespace fskin::gaussian_rasterization {

constexpr int kTileSize = 16;
constexpr int kMaxChannels = 16;

template <typename T>
struct RasterLaunch {
  const T* means2d;     // [N, 2] (u, v) in pixels, OpenCV's pixel centres
  const T* conics;      // [N, 3] (a, b, c): the inverse 2-D covariance [[a, b], [b, c]]
  const T* colors;      // [N, C]
  const T* opacities;   // [N] in [0, 1]
  const T* background;  // [C]
  const int64_t* tile_gaussians;  // [M] Gaussian indices, by tile, front to back within a tile
  const int64_t* tile_ranges;     // [tiles + 1]: tile t's entries are [tile_ranges[t], tile_ranges[t + 1])
  int64_t gaussians;
  int channels;
  int width, height, tiles_x, tiles_y;
  T* image;  // [H, W, C]; the backward reads the forward's
  T* alpha;  // [H, W]; likewise
  // Backward.
  const T* grad_image;  // [H, W, C]
  const T* grad_alpha;  // [H, W], or null
  T* grad_background;   // [H, W, C]: per pixel, summed by the caller
  // Per-Gaussian gradients: on the CPU one row per tile entry [M, K], summed
  // over the entries of each Gaussian in a fixed order afterwards (the same
  // result on every run and thread count); on CUDA one row per Gaussian
  // [N, K], accumulated with atomics. K = kGradientColumns(C).
  T* grad_rows;
};

// A gradient row: d/dmean (2), d/dconic (3), d/dopacity (1), d/dcolour (C).
constexpr int kGradMean = 0, kGradConic = 2, kGradOpacity = 5, kGradColor = 6;
FSKIN_HOST_DEVICE int gradient_columns(int channels) { return kGradColor + channels; }

template <typename T>
FSKIN_HOST_DEVICE T exponential(T x) {
#if defined(__CUDA_ARCH__)
  return exp(x);
#else
  return std::exp(x);
#endif
}

// Gaussian g's alpha at pixel (px, py) before the 0.99 clamp, and whether it
// counts (the exponent is not positive and the clamped alpha reaches 1/255).
template <typename T>
struct Footprint {
  T dx, dy;    // pixel - mean
  T gaussian;  // exp(power)
  T raw;       // o exp(power)
  T alpha;     // min(0.99, raw)
  bool counts;
};

template <typename T>
FSKIN_HOST_DEVICE Footprint<T> footprint(const RasterLaunch<T>& a, int64_t g, T px, T py) {
  Footprint<T> f;
  f.dx = px - a.means2d[2 * g];
  f.dy = py - a.means2d[2 * g + 1];
  const T* q = a.conics + 3 * g;
  const T power = T(-0.5) * (q[0] * f.dx * f.dx + q[2] * f.dy * f.dy) - q[1] * f.dx * f.dy;
  // Most of a tile's list lies far from a given pixel: exp(power) < 1/255
  // there (ln(1/255) = -5.5413), so with o <= 1 the alpha cannot count; no
  // exp is taken. The margin keeps every Gaussian the full test would count.
  if (power < T(-5.55) && a.opacities[g] <= T(1)) {
    f.gaussian = f.raw = f.alpha = T(0);
    f.counts = false;
    return f;
  }
  f.gaussian = exponential(power);
  f.raw = a.opacities[g] * f.gaussian;
  f.alpha = f.raw < T(0.99) ? f.raw : T(0.99);
  // (raw == raw: a NaN opacity draws nothing rather than the clamp's 0.99.)
  f.counts = power <= T(0) && f.alpha >= T(1.0 / 255.0) && f.raw == f.raw;
  return f;
}

// Front to back, one Gaussian at a time: g's step in a pixel's blend given its
// footprint there. Returns false when the pixel stops (before the Gaussian
// that would take T under 1e-4); the pixel then takes no further Gaussians.
template <typename T>
FSKIN_HOST_DEVICE bool blend_step(const RasterLaunch<T>& a, int64_t g, const Footprint<T>& f, T& transmittance,
                                  T* color) {
  if (!f.counts) return true;
  const T next = transmittance * (T(1) - f.alpha);
  if (next < T(1e-4)) return false;
  const T w = f.alpha * transmittance;
  for (int k = 0; k < a.channels; ++k) color[k] += w * a.colors[g * a.channels + k];
  transmittance = next;
  return true;
}

// Pixel p's colour and alpha from its blended colour and final transmittance.
template <typename T>
FSKIN_HOST_DEVICE void write_pixel(const RasterLaunch<T>& a, int64_t p, const T* color, T final_transmittance) {
  for (int k = 0; k < a.channels; ++k) a.image[p * a.channels + k] = color[k] + final_transmittance * a.background[k];
  a.alpha[p] = T(1) - final_transmittance;
}

// Over the tile entries [begin, end) of pixel (x, y)'s tile (the CUDA kernel:
// a thread per pixel).
template <typename T>
FSKIN_HOST_DEVICE void rasterize_pixel(const RasterLaunch<T>& a, int64_t begin, int64_t end, int x, int y) {
  T color[kMaxChannels];
  for (int k = 0; k < a.channels; ++k) color[k] = T(0);
  T transmittance = T(1);
  for (int64_t e = begin; e < end; ++e) {
    const int64_t g = a.tile_gaussians[e];
    if (!blend_step(a, g, footprint(a, g, T(x), T(y)), transmittance, color)) break;
  }
  write_pixel(a, static_cast<int64_t>(y) * a.width + x, color, transmittance);
}

// The backward, pixel by pixel. With C the colour without background, P_i
// its prefix up to and including i, gC / gA the output gradients:
//   dL/dc_i = alpha_i T_i gC,
//   dL/dalpha_i = T_i (c_i . gC) - ((C - P_i) . gC + T_final (bg . gC - gA)) / (1 - alpha_i),
//   dL/dbg = T_final gC;
// then through alpha_i = o_i exp(power_i) (no gradient where the 0.99 clamp
// holds) to the opacity, the mean and the conic. C and T_final come from
// the forward's outputs (a.image, a.alpha): one pass over the list.
//
// What pixel p's backward needs before its first Gaussian: C (`total`, C
// values) and the tail T_final (bg . gC - gA); it also writes dL/dbg's share.
template <typename T>
FSKIN_HOST_DEVICE T begin_pixel_backward(const RasterLaunch<T>& a, int64_t p, T* total) {
  const T final_transmittance = T(1) - a.alpha[p];
  const T* gc = a.grad_image + p * a.channels;
  T background_dot = T(0);
  for (int k = 0; k < a.channels; ++k) {
    total[k] = a.image[p * a.channels + k] - final_transmittance * a.background[k];
    background_dot += a.background[k] * gc[k];
    a.grad_background[p * a.channels + k] = final_transmittance * gc[k];
  }
  const T ga = a.grad_alpha ? a.grad_alpha[p] : T(0);
  return final_transmittance * (background_dot - ga);
}

// Gaussian g's step in pixel p's backward: hands its share of each gradient
// to add(column, value) and advances the pixel's transmittance and prefix.
// Returns false when the pixel stops, as blend_step does.
template <typename T, typename Add>
FSKIN_HOST_DEVICE bool backward_step(const RasterLaunch<T>& a, int64_t p, int64_t g, const Footprint<T>& f,
                                     const T* total, T tail, T& transmittance, T* prefix, Add&& add) {
  if (!f.counts) return true;
  const T next = transmittance * (T(1) - f.alpha);
  if (next < T(1e-4)) return false;
  const T w = f.alpha * transmittance;
  const T* c = a.colors + g * a.channels;
  const T* gc = a.grad_image + p * a.channels;
  T own = T(0), after = T(0);
  for (int k = 0; k < a.channels; ++k) {
    prefix[k] += w * c[k];
    own += c[k] * gc[k];
    after += (total[k] - prefix[k]) * gc[k];
    add(kGradColor + k, w * gc[k]);
  }
  const T grad_alpha = transmittance * own - (after + tail) / (T(1) - f.alpha);
  transmittance = next;
  if (f.raw > T(0.99)) return true;  // clamped: alpha does not move with o or the footprint
  add(kGradOpacity, grad_alpha * f.gaussian);
  const T grad_power = grad_alpha * f.raw;
  const T* q = a.conics + 3 * g;
  // power = -1/2 (a dx^2 + c dy^2) - b dx dy with d = pixel - mean.
  add(kGradMean + 0, grad_power * (q[0] * f.dx + q[1] * f.dy));
  add(kGradMean + 1, grad_power * (q[2] * f.dy + q[1] * f.dx));
  add(kGradConic + 0, grad_power * T(-0.5) * f.dx * f.dx);
  add(kGradConic + 1, -grad_power * f.dx * f.dy);
  add(kGradConic + 2, grad_power * T(-0.5) * f.dy * f.dy);
  return true;
}

template <typename T, typename Add>
FSKIN_HOST_DEVICE void rasterize_pixel_backward(const RasterLaunch<T>& a, int64_t begin, int64_t end, int x, int y,
                                                Add&& add) {
  const int64_t p = static_cast<int64_t>(y) * a.width + x;
  T total[kMaxChannels], prefix[kMaxChannels];
  const T tail = begin_pixel_backward(a, p, total);
  for (int k = 0; k < a.channels; ++k) prefix[k] = T(0);
  T transmittance = T(1);
  for (int64_t e = begin; e < end; ++e) {
    const int64_t g = a.tile_gaussians[e];
    const bool going = backward_step(a, p, g, footprint(a, g, T(x), T(y)), total, tail, transmittance, prefix,
                                     [&](int column, T value) { add(e, g, column, value); });
    if (!going) break;
  }
}

// The pixels where Gaussian g can count lie within half_x / half_y pixels of
// its mean: counting needs o exp(power) >= 1/255, i.e. d^T Q d <= 2 ln(255 o),
// an ellipse whose box has half-widths sqrt(k Q^-1_xx), sqrt(k Q^-1_yy)
// (widened by 0.1 % for rounding). Negative half-widths: no pixel counts.
// Returns false where there is no such bound (a conic that is not positive
// definite, an opacity above 1 or not finite): then every pixel is tested.
template <typename T>
FSKIN_HOST_DEVICE bool footprint_reach(const RasterLaunch<T>& a, int64_t g, T& half_x, T& half_y) {
  const T o = a.opacities[g];
  const T* q = a.conics + 3 * g;
  const T det = q[0] * q[2] - q[1] * q[1];
  if (!(o <= T(1)) || !(q[0] > T(0)) || !(q[2] > T(0)) || !(det > T(0))) return false;
  if (!(det < T(1e30)) || !(q[0] < T(1e30)) || !(q[2] < T(1e30))) return false;
  if (T(255) * o < T(1)) {
    half_x = half_y = T(-1);
    return true;
  }
#if defined(__CUDA_ARCH__)
  const T k = T(2) * log(T(255) * o) * T(1.001) + T(1e-3);
  half_x = sqrt(k * q[2] / det);
  half_y = sqrt(k * q[0] / det);
#else
  const T k = T(2) * std::log(T(255) * o) * T(1.001) + T(1e-3);
  half_x = std::sqrt(k * q[2] / det);
  half_y = std::sqrt(k * q[0] / det);
#endif
  return true;
}

template <typename T>
void rasterize_cpu(const RasterLaunch<T>& launch, bool backward);

// Raw device pointers; `stream` is a cudaStream_t. Defined in cuda/ (no LibTorch there).
template <typename T>
void rasterize_cuda(const RasterLaunch<T>& launch, bool backward, void* stream);

}  // namespace fskin::gaussian_rasterization
