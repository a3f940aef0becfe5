#pragma once
// The plain-pointer math of a fused PIN pass (INS eq. 13-14): every coupling
// layer of one PIN applied to points held in registers (one per lane), with the
// per-frame parameters already folded (invertible/fused_pin_pass.h). The CPU
// kernel runs it on a GCC vector of 16 points (one AVX-512 register per value),
// the CUDA kernel on one float per thread. Torch-free so nvcc compiles it.
//
// Packed parameters of one frame, per coupling layer k at layer_offset[k]:
//   SIREN sine layers (eq. 8), each: w0 W [out, in] row-major, w0 b [out]
//   then per operation map (2D layer: rotation, translation; 1D: translation),
//   eq. 9-12 with the first layer folded for this frame's pose embedding and
//   the maps' Softplus(beta) (x) = softplus(beta x) / beta rewritten on
//   u = beta x, so the kernel runs plain softplus and never multiplies by beta:
//     beta A [hidden, features], beta a [hidden]   (u = beta (A f + a))
//     (map_layers - 1) x { W [hidden, hidden], beta b [hidden] }
//     W_last / beta [out, hidden], centre [out]    (map = W_last h - centre)
#include <cstdint>

#include "ops/pin_pass/vector_math.h"

namespace fskin::pin_pass {

constexpr int kMaxLayers = 64;
constexpr int kMaxWidth = 256;  // widest SIREN feature or map hidden layer

struct PinShape {
  int layers;
  int moved_count[kMaxLayers];  // 2: a 2D layer, 1: a 1D layer
  int moved[kMaxLayers][2];     // axes the layer moves (rotation from [0] towards [1])
  int kept[kMaxLayers][2];      // axes it is conditioned on (moved_count 2 -> one)
  int64_t layer_offset[kMaxLayers];
  int sine_layers;   // sine layers of each SIREN
  int siren_hidden;  // width of all but the last sine layer
  int features;      // width of the last sine layer
  int map_hidden;
  int map_layers;    // hidden layers of each map (>= 1)
};

// Floats one layer packs (see the layout above).
inline int64_t packed_layer_size(const PinShape& s, int moved_count) {
  int64_t n = 0;
  int in = 3 - moved_count;
  for (int l = 0; l < s.sine_layers; ++l) {
    const int out = l + 1 == s.sine_layers ? s.features : s.siren_hidden;
    n += static_cast<int64_t>(out) * in + out;
    in = out;
  }
  const int outputs = moved_count == 2 ? 3 : 1;  // angle + 2D translation, or 1D translation
  const int maps = moved_count == 2 ? 2 : 1;
  n += maps * (static_cast<int64_t>(s.map_hidden) * s.features + s.map_hidden);
  n += maps * (s.map_layers - 1) * (static_cast<int64_t>(s.map_hidden) * s.map_hidden + s.map_hidden);
  n += static_cast<int64_t>(outputs) * s.map_hidden + outputs;
  return n;
}

// out[o] = activation(bias[o] + sum_i weight[o][i] in[i]); returns the pointer
// past the weights and bias. V: float (one point) or a GCC vector (one point
// per lane). Eight outputs at a time: eight independent multiply-add chains
// hide the FMA latency that a single running sum would wait on every step; the
// activation runs on them while they are still in registers.
template <typename V, typename Activation>
FSKIN_KERNEL_INLINE const float* dense(const float* p, const V* in, int in_dim, int out_dim, V* out,
                                       Activation activation) {
  constexpr int kBlock = 8;
  const float* bias = p + static_cast<int64_t>(out_dim) * in_dim;
  int o = 0;
  for (; o + kBlock <= out_dim; o += kBlock) {
    V acc[kBlock];
    for (int j = 0; j < kBlock; ++j) acc[j] = vector_math::splat<V>(bias[o + j]);
    const float* w = p + static_cast<int64_t>(o) * in_dim;
    for (int i = 0; i < in_dim; ++i) {
      const V v = in[i];
      for (int j = 0; j < kBlock; ++j) acc[j] += w[j * in_dim + i] * v;
    }
    for (int j = 0; j < kBlock; ++j) out[o + j] = activation(acc[j]);
  }
  for (; o < out_dim; ++o) {
    V acc = vector_math::splat<V>(bias[o]);
    const float* w = p + static_cast<int64_t>(o) * in_dim;
    for (int i = 0; i < in_dim; ++i) acc += w[i] * in[i];
    out[o] = activation(acc);
  }
  return bias + out_dim;
}

// The two activations, as function objects dense() can inline.
struct Sine {
  template <typename V>
  FSKIN_KERNEL_INLINE V operator()(V x) const {
    return vector_math::sin(x);
  }
};
struct Softplus {
  template <typename V>
  FSKIN_KERNEL_INLINE V operator()(V x) const {
    return vector_math::softplus(x);
  }
};

// One operation map on the features f: writes out_dim values to out.
template <typename V>
FSKIN_KERNEL_INLINE const float* operation_map(const PinShape& s, const float* p, const V* f, int out_dim, V* h, V* g,
                                               V* out) {
  p = dense(p, f, s.features, s.map_hidden, h, Softplus{});
  for (int k = 1; k < s.map_layers; ++k) {
    p = dense(p, h, s.map_hidden, s.map_hidden, g, Softplus{});
    V* const next = g;  // the two buffers swap roles
    g = h;
    h = next;
  }
  // Last layer (no bias), minus the map at the zero pose (centring).
  const float* centre = p + static_cast<int64_t>(out_dim) * s.map_hidden;
  for (int o = 0; o < out_dim; ++o) {
    V acc = vector_math::splat<V>(-centre[o]);
    for (int i = 0; i < s.map_hidden; ++i) acc += p[o * s.map_hidden + i] * h[i];
    out[o] = acc;
  }
  return centre + out_dim;
}

// Scratch of one block: two SIREN / map buffers and the features.
template <typename V>
struct Scratch {
  V a[kMaxWidth], b[kMaxWidth], features[kMaxWidth];
};

// Applies the PIN (inverse = false, eq. 13) or its inverse (eq. 14) in place
// to the points x[3] (x, y, z) of one frame.
template <typename V>
FSKIN_KERNEL_INLINE void pin_block(const PinShape& s, const float* params, bool inverse, V* x, Scratch<V>& t) {
  for (int step = 0; step < s.layers; ++step) {
    const int k = inverse ? s.layers - 1 - step : step;
    const int moved = s.moved_count[k];
    const float* p = params + s.layer_offset[k];
    // z_s from the kept coordinates, which forward and inverse share (eq. 8).
    int in = 3 - moved;
    for (int i = 0; i < in; ++i) t.a[i] = x[s.kept[k][i]];
    for (int layer = 0; layer < s.sine_layers; ++layer) {
      const bool last = layer + 1 == s.sine_layers;
      const int out = last ? s.features : s.siren_hidden;
      V* dst = last ? t.features : (layer % 2 == 0 ? t.b : t.a);
      const V* src = layer % 2 == 0 ? t.a : t.b;
      p = dense(p, src, in, out, dst, Sine{});
      in = out;
    }
    V coupling[3];
    if (moved == 2) {
      p = operation_map(s, p, t.features, 1, t.a, t.b, coupling);      // theta (eq. 10)
      p = operation_map(s, p, t.features, 2, t.a, t.b, coupling + 1);  // t (eq. 11)
      const int u_axis = s.moved[k][0], v_axis = s.moved[k][1];
      // cos via sin(theta + pi/2): one vectorised function for both.
      const V c = vector_math::sin(coupling[0] + 1.57079632679489662f), sn = vector_math::sin(coupling[0]);
      V u = x[u_axis], v = x[v_axis];
      if (!inverse) {  // eq. 5: y = R x + t
        x[u_axis] = c * u - sn * v + coupling[1];
        x[v_axis] = sn * u + c * v + coupling[2];
      } else {  // eq. 6: x = R^T (y - t)
        u -= coupling[1];
        v -= coupling[2];
        x[u_axis] = c * u + sn * v;
        x[v_axis] = c * v - sn * u;
      }
    } else {
      operation_map(s, p, t.features, 1, t.a, t.b, coupling);  // eq. 12
      const int axis = s.moved[k][0];
      x[axis] = inverse ? x[axis] - coupling[0] : x[axis] + coupling[0];
    }
  }
}

}  // namespace fskin::pin_pass
