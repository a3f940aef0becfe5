// CPU kernels of the hash encoding: at::parallel_for over points (forward,
// position gradient) and over levels for the table gradient, whose scatter
// then needs no atomics: each level's rows belong to one thread.
#include <ATen/Parallel.h>

#include "ops/hash_encoding/hash_encoding_kernel.h"

namespace fskin::hash_grid {

template <typename T>
void hash_encoding_forward_cpu(const EncodingLaunch<T>& a) {
  for (int64_t l = 0; l < a.levels; ++l) {
    at::parallel_for(0, a.points, 4096, [&](int64_t begin, int64_t end) {
      for (int64_t n = begin; n < end; ++n) encode_point(a, n, l);
    });
  }
}

template <typename T>
void hash_encoding_backward_cpu(const EncodingLaunch<T>& a) {
  if (a.grad_table) {
    at::parallel_for(0, a.levels, 1, [&](int64_t first, int64_t last) {
      Cell<T> cell;
      for (int64_t l = first; l < last; ++l) {
        T* level = a.grad_table + l * a.table_size * a.features;
        for (int64_t n = 0; n < a.points; ++n) {
          locate(a.positions + 3 * n, a.resolution[l], a.hashed[l], a.table_size, false, cell);
          const T* grad = a.grad_out + n * a.levels * a.features + l * a.features;
          for (int c = 0; c < 8; ++c) {
            T* row = level + cell.row[c] * a.features;
            for (int64_t f = 0; f < a.features; ++f) row[f] += cell.weight[c] * grad[f];
          }
        }
      }
    });
  }
  if (a.grad_positions) {
    at::parallel_for(0, a.points, 1024, [&](int64_t begin, int64_t end) {
      for (int64_t n = begin; n < end; ++n) position_gradient(a, n);
    });
  }
}

template void hash_encoding_forward_cpu<float>(const EncodingLaunch<float>&);
template void hash_encoding_forward_cpu<double>(const EncodingLaunch<double>&);
template void hash_encoding_backward_cpu<float>(const EncodingLaunch<float>&);
template void hash_encoding_backward_cpu<double>(const EncodingLaunch<double>&);

}  // namespace fskin::hash_grid
