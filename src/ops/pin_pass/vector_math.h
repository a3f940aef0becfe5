#pragma once
// sin and Softplus(beta = 100) as branch-free polynomials, written once for a
// float (the CUDA kernel: one point per thread) and for a GCC vector of floats
// (the CPU kernel: 16 points per register). Written by hand because libm's
// sinf / expf / log1pf are calls the compiler does not vectorise without
// -ffast-math (glibc declares its SIMD variants only then), and SLEEF would
// need one dispatch per instruction set; both devices also compute the same
// numbers this way. Only +, *, / and comparisons-with-select, so every
// instruction set vectorises them. Needs IEEE arithmetic: -ffast-math would
// fold round_nearest away. Accuracy (tests/ops/pin_pass_test.cpp): sin within
// 2e-7 absolute for |x| <= 100, Softplus within 1e-7 absolute.
#include <cstdint>
#include <cstring>

// Forced inlining on the host too: the CPU kernel is compiled once per
// instruction set (target_clones), and only code inlined into it gets the wide
// vectors; an out-of-line helper would run at the baseline (SSE2) width.
#if defined(__CUDACC__)
#define FSKIN_KERNEL_INLINE __host__ __device__ __forceinline__
#else
#define FSKIN_KERNEL_INLINE inline __attribute__((always_inline))
#endif

namespace fskin::vector_math {

// c in every lane of V (V = float, or a GCC vector of floats).
template <typename V>
FSKIN_KERNEL_INLINE V splat(float c) {
  return V{} + c;
}

// 2^n for integer-valued n in [-127, 127], built in the exponent bits.
FSKIN_KERNEL_INLINE float pow2(float n) {
  const int32_t bits = (static_cast<int32_t>(n) + 127) << 23;
#if defined(__CUDA_ARCH__)
  return __int_as_float(bits);
#else
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
#endif
}

#if !defined(__CUDACC__)
// The same for a GCC vector of floats (a cast between equal-sized vector
// types reinterprets the bits).
template <typename V, typename = decltype(V{}[0])>
FSKIN_KERNEL_INLINE V pow2(V n) {
  using Int = decltype(n < n);  // the int32 vector of V's shape
  return reinterpret_cast<V>((__builtin_convertvector(n, Int) + 127) << 23);
}
#endif

// Round to the nearest integer (|x| < 2^22) by adding and removing 1.5 x 2^23.
template <typename V>
FSKIN_KERNEL_INLINE V round_nearest(V x) {
  const V magic = splat<V>(12582912.0f);
  return (x + magic) - magic;
}

// sin(x) = (-1)^n sin(r), x = n pi + r, |r| <= pi / 2; pi in three parts
// (Cody-Waite) so r keeps float precision for |x| up to ~1e4; Taylor to r^11
// (truncation < 6e-8 at pi / 2).
template <typename V>
FSKIN_KERNEL_INLINE V sin(V x) {
  const V n = round_nearest(x * 0.318309886183790672f);
  V r = x - n * 3.140625f;
  r = r - n * 9.67502593994140625e-4f;
  r = r - n * 1.509957990978376432e-7f;
  const V r2 = r * r;
  V p = splat<V>(-2.5052108385441720e-8f);  // -1/11!
  p = p * r2 + 2.7557319223985893e-6f;
  p = p * r2 - 1.9841269841269841e-4f;
  p = p * r2 + 8.3333333333333333e-3f;
  p = p * r2 - 1.6666666666666667e-1f;
  const V s = r + r * r2 * p;
  // (-1)^n without integers: half = n/2 - round(n/2) is 0 (n even) or +-1/2.
  const V half = n * 0.5f - round_nearest(n * 0.5f);
  return s * (1.0f - 8.0f * half * half);
}

// exp(t) for t <= 0, clamped at t = -40 (4e-18): below that the result and
// squares of it in log1p_unit would be subnormal floats, which cost a
// microcode assist each (measured: the whole PIN pass ran 5x slower).
// t = n ln2 + r, |r| <= ln2 / 2, Taylor to r^7 (error < 2e-9 relative), times 2^n.
template <typename V>
FSKIN_KERNEL_INLINE V exp_nonpositive(V t) {
  const V lowest = splat<V>(-40.0f);
  t = t < lowest ? lowest : t;
  const V n = round_nearest(t * 1.44269504088896341f);
  V r = t - n * 0.693145751953125f;
  r = r - n * 1.428606765330187045e-6f;
  V p = splat<V>(1.9841269841269841e-4f);  // 1/7!
  p = p * r + 1.3888888888888889e-3f;
  p = p * r + 8.3333333333333333e-3f;
  p = p * r + 4.1666666666666667e-2f;
  p = p * r + 1.6666666666666667e-1f;
  p = p * r + 0.5f;
  p = p * r + 1.0f;
  p = p * r + 1.0f;
  return p * pow2(n);
}

// log(1 + u) for u in [0, 1]: 2 atanh(s) with s = u / (2 + u) in [0, 1/3],
// series to s^15 (truncation < 2e-9).
template <typename V>
FSKIN_KERNEL_INLINE V log1p_unit(V u) {
  const V s = u / (2.0f + u), s2 = s * s;
  V p = splat<V>(1.0f / 15.0f);
  p = p * s2 + 1.0f / 13.0f;
  p = p * s2 + 1.0f / 11.0f;
  p = p * s2 + 1.0f / 9.0f;
  p = p * s2 + 1.0f / 7.0f;
  p = p * s2 + 1.0f / 5.0f;
  p = p * s2 + 1.0f / 3.0f;
  p = p * s2 + 1.0f;
  return 2.0f * s * p;
}

// Softplus with beta = 100, the activation of networks/mlp.h and the INS maps:
// log(1 + exp(100 x)) / 100 = (max(z, 0) + log1p(exp(-|z|))) / 100, z = 100 x.
// (PyTorch switches to x above z = 20; the two differ there by < 3e-11.)
template <typename V>
FSKIN_KERNEL_INLINE V softplus100(V x) {
  const V z = 100.0f * x, zero = splat<V>(0.0f);
  const V magnitude = z < zero ? -z : z;
  const V positive = z > zero ? z : zero;
  return (positive + log1p_unit(exp_nonpositive(-magnitude))) * 0.01f;
}

}  // namespace fskin::vector_math
