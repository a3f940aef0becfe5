#pragma once
// sin and Softplus(beta = 100) without branches, written once for a float
// (the CUDA kernel: one point per thread) and for a GCC vector of floats (the
// CPU kernel: 16 points per register). Written by hand because libm's sinf /
// expf / log1pf are calls the compiler does not vectorise without -ffast-math
// (glibc declares its SIMD variants only then), and SLEEF would need one
// dispatch per instruction set; both devices also compute the same numbers
// this way. sin: a polynomial; Softplus: a table of polynomials. Needs IEEE
// arithmetic: -ffast-math would fold round_nearest away. Accuracy
// (tests/ops/pin_pass_test.cpp): sin within 2e-7 absolute for |x| <= 100,
// softplus within 2e-6 absolute.
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

// (-1)^n s for integer-valued n (|n| < 2^31): the parity of n flips the sign bit.
FSKIN_KERNEL_INLINE float flip_sign_if_odd(float s, float n) {
  const uint32_t sign = static_cast<uint32_t>(static_cast<int32_t>(n)) << 31;
#if defined(__CUDA_ARCH__)
  return __uint_as_float(__float_as_uint(s) ^ sign);
#else
  uint32_t bits;
  std::memcpy(&bits, &s, sizeof bits);
  bits ^= sign;
  std::memcpy(&s, &bits, sizeof s);
  return s;
#endif
}

#if !defined(__CUDACC__)
// The uint32 vector of `Bytes` bytes (a struct, since GCC drops the attribute
// from an alias template).
template <int Bytes>
struct UnsignedVector {
  typedef uint32_t type __attribute__((vector_size(Bytes)));
};

// The same for a GCC vector of floats (a cast between equal-sized vector
// types reinterprets the bits).
template <typename V, typename = decltype(V{}[0])>
FSKIN_KERNEL_INLINE V flip_sign_if_odd(V s, V n) {
  using Int = decltype(n < n);  // the int32 vector of V's shape
  using UInt = typename UnsignedVector<sizeof(V)>::type;
  const UInt sign = reinterpret_cast<UInt>(__builtin_convertvector(n, Int)) << 31;
  return reinterpret_cast<V>(reinterpret_cast<UInt>(s) ^ sign);
}
#endif

// Round to the nearest integer (|x| < 2^22) by adding and removing 1.5 x 2^23.
template <typename V>
FSKIN_KERNEL_INLINE V round_nearest(V x) {
  const V magic = splat<V>(12582912.0f);
  return (x + magic) - magic;
}

// sin(x) = (-1)^n sin(r), x = n pi + r, |r| <= pi / 2; pi in three parts
// (Cody-Waite) so r keeps float precision for |x| up to ~1e4; then
// r + r^3 q(r^2) with q cubic, least squares on |r| <= pi / 2
// (tools/fit_vector_math.py; error 1.2e-7, float rounding: Taylor needs one
// degree more for that).
template <typename V>
FSKIN_KERNEL_INLINE V sin(V x) {
  const V n = round_nearest(x * 0.318309886183790672f);
  V r = x - n * 3.140625f;
  r = r - n * 9.67502593994140625e-4f;
  r = r - n * 1.509957990978376432e-7f;
  const V r2 = r * r;
  V p = splat<V>(2.60655383e-06f);
  p = p * r2 - 0.000198095804f;
  p = p * r2 + 0.0083330581f;
  p = p * r2 - 0.166666582f;
  return flip_sign_if_odd(r + r * r2 * p, n);
}

// log(1 + exp(-a)) for a >= 0 as one degree-4 polynomial in t = a - i per
// unit interval [i, i + 1), i = 0..15, and 0 from a = 16 on (where it is
// < 1.2e-7): Chebyshev interpolation per interval, rows c[k][i] = coefficient
// of t^k, printed by tools/fit_vector_math.py (worst error 1.8e-6, never
// negative). Replaces exp + log1p (a division and two polynomials): the PIN's
// maps evaluate it once per hidden unit, half the pass's arithmetic before.
constexpr int kTableIntervals = 16, kTableDegree = 4;
#define FSKIN_LOG1P_EXP_NEGATIVE_TABLE                                                                               \
  {{0.693148613f, 0.313263059f, 0.126927927f, 0.0485870577f, 0.0181497671f, 0.00671528047f, 0.0024756589f,            \
    0.000911456649f, 0.000335402758f, 0.000123400852f, 4.53984067e-05f, 1.67013804e-05f, 6.14412693e-06f,             \
    2.26030238e-06f, 8.31519344e-07f, 3.05898965e-07f},                                                               \
   {-0.500071645f, -0.269010335f, -0.119198799f, -0.0474111885f, -0.0179781169f, -0.00668945024f, -0.00247131148f,    \
    -0.000910560309f, -0.000335168414f, -0.000123327569f, -4.53731955e-05f, -1.66923419e-05f, -6.1408341e-06f,        \
    -2.25909548e-06f, -8.31075909e-07f, -3.05735909e-07f},                                                            \
   {0.125552267f, 0.09886989f, 0.0524695441f, 0.0224703401f, 0.00876569655f, 0.00329636084f, 0.0012225731f,           \
    0.000451111497f, 0.000166138168f, 6.11436772e-05f, 2.2496868e-05f, 8.27659096e-06f, 3.04484934e-06f,              \
    1.12014584e-06f, 4.12079743e-07f, 1.51595827e-07f},                                                               \
   {-0.00141279481f, -0.0167976264f, -0.0132876905f, -0.00648208894f, -0.00264833844f, -0.001012792f,                \
    -0.000377949356f, -0.000139773416f, -5.15194333e-05f, -1.89664479e-05f, -6.9791954e-06f, -2.56775024e-06f,        \
    -9.44655994e-07f, -3.47524065e-07f, -1.27847571e-07f, -4.70325752e-08f},                                          \
   {-0.00395656703f, 0.000601978682f, 0.00167655991f, 0.000986082479f, 0.000426482584f, 0.000166343874f,             \
    6.25175308e-05f, 2.3180226e-05f, 8.55218059e-06f, 3.14951308e-06f, 1.1590937e-06f, 4.26468006e-07f,               \
    1.56897102e-07f, 5.77203387e-08f, 2.12342783e-08f, 7.81167486e-09f}}
inline constexpr float kLog1pExpNegative[kTableDegree + 1][kTableIntervals] = FSKIN_LOG1P_EXP_NEGATIVE_TABLE;
#if defined(__CUDACC__)
static __constant__ float kLog1pExpNegativeDevice[kTableDegree + 1][kTableIntervals] = FSKIN_LOG1P_EXP_NEGATIVE_TABLE;
#endif
#undef FSKIN_LOG1P_EXP_NEGATIVE_TABLE

// The largest a the table covers, just below 16 so that int(a) <= 15.
constexpr float kTableEnd = 15.9999f;

FSKIN_KERNEL_INLINE float log1p_exp_negative(float a) {
  const float clamped = a < kTableEnd ? a : kTableEnd;
  const int i = static_cast<int>(clamped);
  const float t = clamped - static_cast<float>(i);
#if defined(__CUDA_ARCH__)
  const auto& c = kLog1pExpNegativeDevice;
#else
  const auto& c = kLog1pExpNegative;
#endif
  float p = c[kTableDegree][i];
  for (int k = kTableDegree - 1; k >= 0; --k) p = p * t + c[k][i];
  return a < 16.0f ? p : 0.0f;
}

#if !defined(__CUDACC__)
// The same for 16 lanes: each coefficient row is one register, and a lane's
// coefficient is a variable permute of it (vpermps on AVX-512). The interval
// index saturates at 15 as an integer; lanes past the table get garbage t but
// are zeroed at the end.
template <typename V, typename = decltype(V{}[0])>
FSKIN_KERNEL_INLINE V log1p_exp_negative(V a) {
  static_assert(sizeof(V) == kTableIntervals * sizeof(float), "the table lookup permutes 16 lanes");
  using Int = decltype(a < a);
  Int i = __builtin_convertvector(a, Int);
  i = i < kTableIntervals - 1 ? i : kTableIntervals - 1;
  const V t = a - __builtin_convertvector(i, V);
  const auto row = [&](int k) {
    V r;
    std::memcpy(&r, kLog1pExpNegative[k], sizeof r);
    return __builtin_shuffle(r, i);
  };
  V p = row(kTableDegree);
  for (int k = kTableDegree - 1; k >= 0; --k) p = p * t + row(k);
  return a < splat<V>(16.0f) ? p : splat<V>(0.0f);
}

// |x| by clearing the sign bit (one AND instead of compare and select).
template <typename V, typename = decltype(V{}[0])>
FSKIN_KERNEL_INLINE V magnitude(V x) {
  using Int = decltype(x < x);
  return reinterpret_cast<V>(reinterpret_cast<Int>(x) & 0x7fffffff);
}
#endif

FSKIN_KERNEL_INLINE float magnitude(float x) { return x < 0.0f ? -x : x; }

// Softplus log(1 + exp(z)) = max(z, 0) + log1p(exp(-|z|)), max(z, 0) = (z + |z|) / 2.
// The INS maps' Softplus(beta) (x) = softplus(beta x) / beta: the fused pass
// folds both factors of beta into its packed weights (pin_pass_core.h).
template <typename V>
FSKIN_KERNEL_INLINE V softplus(V z) {
  const V a = magnitude(z);
  return (z + a) * 0.5f + log1p_exp_negative(a);
}

}  // namespace fskin::vector_math
