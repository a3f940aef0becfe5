#pragma once
// Raw-pointer arguments and per-lane bodies of the broyden_lanes op, shared by
// its CPU and CUDA kernels. Torch-free so nvcc compiles it.
#include <cstdint>

#include "ops/broyden_search/broyden_core.h"
#include "ops/broyden_search/start_selection.h"

namespace fskin::broyden {

template <typename T>
struct LanesView {
  T* x;              // [P, 3]
  T* jinv;           // [P, 9]
  T* residual;       // [P, 3]
  T* step;           // [P, 3]
  uint8_t* state;    // [P] LaneState
  uint8_t* iterations;  // [P]
  int64_t lanes;     // P
};

template <typename T>
FSKIN_HOST_DEVICE void start_lane(const LanesView<T>& v, const T* jacobian, int64_t p) {
  initial_inverse_jacobian(jacobian + 9 * p, 3, v.jinv + 9 * p);
  v.state[p] = static_cast<uint8_t>(LaneState::Active);
  v.iterations[p] = 0;
}

template <typename T>
FSKIN_HOST_DEVICE void step_lane(const LanesView<T>& v, int k, const SearchParams<T>& params, int64_t p) {
  if (v.state[p] != static_cast<uint8_t>(LaneState::Active)) return;
  const LaneState s = broyden_step(v.x + 3 * p, v.jinv + 9 * p, v.residual + 3 * p, v.step + 3 * p, k, params);
  v.state[p] = static_cast<uint8_t>(s);
  v.iterations[p] = static_cast<uint8_t>(s == LaneState::Active ? k + 1 : k);
}

template <typename T>
FSKIN_HOST_DEVICE void update_lane(const LanesView<T>& v, const int64_t* stepped, const T* residual, T eps,
                                   int64_t i) {
  const int64_t p = stepped[i];
  broyden_absorb(v.jinv + 9 * p, v.residual + 3 * p, v.step + 3 * p, residual + 3 * i, eps);
}

// Row p of rank_starts: own weights [P, S] -> start indices [P, count].
template <typename T>
FSKIN_HOST_DEVICE void rank_row(const T* own_weights, int starts, int count, int64_t* out, int64_t p) {
  T scores[kMaxRankedStarts];
  for (int s = 0; s < starts; ++s) scores[s] = score_from_weight(own_weights[p * starts + s]);
  for (int r = 0; r < count; ++r) out[p * count + r] = start_of_rank(scores, starts, r);
}

template <typename T>
void start_lanes_cpu(const LanesView<T>& v, const T* jacobian);
template <typename T>
void step_lanes_cpu(const LanesView<T>& v, int k, const SearchParams<T>& params);
template <typename T>
void update_lanes_cpu(const LanesView<T>& v, const int64_t* stepped, const T* residual, int64_t count, T eps);
template <typename T>
void rank_starts_cpu(const T* own_weights, int64_t points, int starts, int count, int64_t* out);

// Raw device pointers; `stream` is a cudaStream_t. Defined in cuda/.
template <typename T>
void start_lanes_cuda(const LanesView<T>& v, const T* jacobian, void* stream);
template <typename T>
void step_lanes_cuda(const LanesView<T>& v, int k, const SearchParams<T>& params, void* stream);
template <typename T>
void update_lanes_cuda(const LanesView<T>& v, const int64_t* stepped, const T* residual, int64_t count, T eps,
                       void* stream);
template <typename T>
void rank_starts_cuda(const T* own_weights, int64_t points, int starts, int count, int64_t* out, void* stream);

}  // namespace fskin::broyden
