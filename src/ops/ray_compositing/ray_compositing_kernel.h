#pragma once
// Raw-pointer arguments of the compositing launches, the per-ray forward and
// backward both devices run, and the device kernels (cpu/, cuda/). Torch-free
// so nvcc compiles it.
#include <cmath>
#include <cstdint>

#include "ops/common/host_device.h"

namespace fskin::ray_compositing {

template <typename T>
struct CompositeLaunch {
  const T* sigma;       // [R, S]
  const T* rgb;         // [R, S, 3]
  const T* delta;       // [R, S]
  const T* background;  // [R, 3]
  int64_t rays, samples;
  T* color;             // [R, 3]
  T* opacity;           // [R]
  const T* grad_color;    // backward: [R, 3]
  const T* grad_opacity;  // backward: [R]
  T* grad_sigma;          // backward: [R, S], or null when not needed
  T* grad_rgb;            // backward: [R, S, 3], or null
  T* grad_delta;          // backward: [R, S], or null
  T* grad_background;     // backward: [R, 3], or null
};

template <typename T>
FSKIN_HOST_DEVICE T transmittance_factor(T sigma, T delta) {  // 1 - alpha
#if defined(__CUDA_ARCH__)
  return exp(-sigma * delta);
#else
  return std::exp(-sigma * delta);
#endif
}

// Front to back over ray r's samples; returns T_final.
template <typename T>
FSKIN_HOST_DEVICE T composite_forward(const CompositeLaunch<T>& a, int64_t r, T color[3]) {
  T transmittance = T(1);
  color[0] = color[1] = color[2] = T(0);
  for (int64_t s = 0; s < a.samples; ++s) {
    const int64_t i = r * a.samples + s;
    const T keep = transmittance_factor(a.sigma[i], a.delta[i]);
    const T w = transmittance * (T(1) - keep);
    for (int k = 0; k < 3; ++k) color[k] += w * a.rgb[3 * i + k];
    transmittance *= keep;
  }
  return transmittance;
}

template <typename T>
FSKIN_HOST_DEVICE void composite_ray(const CompositeLaunch<T>& a, int64_t r) {
  T color[3];
  const T final_transmittance = composite_forward(a, r, color);
  for (int k = 0; k < 3; ++k) a.color[3 * r + k] = color[k] + final_transmittance * a.background[3 * r + k];
  a.opacity[r] = T(1) - final_transmittance;
}

// dL/dc_s = w_s gC;
// dL/dsigma_s = delta_s X_s, dL/ddelta_s = sigma_s X_s (alpha depends on their product), with
// X_s = T_{s+1} (c_s . gC) - (C - C_{<=s}) . gC - T_final (bg . gC) + T_final gA,
// C the ray's colour without background and C_{<=s} its prefix sum;
// dL/dbg = T_final gC.
template <typename T>
FSKIN_HOST_DEVICE void composite_ray_backward(const CompositeLaunch<T>& a, int64_t r) {
  T total[3];
  const T final_transmittance = composite_forward(a, r, total);
  const T* gc = a.grad_color + 3 * r;
  const T ga = a.grad_opacity ? a.grad_opacity[r] : T(0);
  const T* bg = a.background + 3 * r;
  const T tail = final_transmittance * (ga - (bg[0] * gc[0] + bg[1] * gc[1] + bg[2] * gc[2]));
  if (a.grad_background) {
    for (int k = 0; k < 3; ++k) a.grad_background[3 * r + k] = final_transmittance * gc[k];
  }
  T transmittance = T(1);
  T prefix[3] = {T(0), T(0), T(0)};
  for (int64_t s = 0; s < a.samples; ++s) {
    const int64_t i = r * a.samples + s;
    const T keep = transmittance_factor(a.sigma[i], a.delta[i]);
    const T w = transmittance * (T(1) - keep);
    const T* c = a.rgb + 3 * i;
    T after = T(0);  // (C - C_{<=s}) . gC
    T own = T(0);    // c_s . gC
    for (int k = 0; k < 3; ++k) {
      prefix[k] += w * c[k];
      after += (total[k] - prefix[k]) * gc[k];
      own += c[k] * gc[k];
      if (a.grad_rgb) a.grad_rgb[3 * i + k] = w * gc[k];
    }
    transmittance *= keep;
    const T x = transmittance * own - after + tail;
    if (a.grad_sigma) a.grad_sigma[i] = a.delta[i] * x;
    if (a.grad_delta) a.grad_delta[i] = a.sigma[i] * x;
  }
}

template <typename T>
void composite_rays_cpu(const CompositeLaunch<T>& launch, bool backward);

// Raw device pointers; `stream` is a cudaStream_t. Defined in cuda/ (no LibTorch there).
template <typename T>
void composite_rays_cuda(const CompositeLaunch<T>& launch, bool backward, void* stream);

}  // namespace fskin::ray_compositing
