// CPU kernel of grid_forward_skinning: at::parallel_for over points.
#include <ATen/Parallel.h>

#include "ops/grid_forward_skinning/grid_forward_skinning_kernel.h"

namespace fskin::grid_skinning {

template <typename T>
void grid_forward_skinning_cpu(const SkinningLaunch<T>& a) {
  at::parallel_for(0, a.batch * a.points, 4096, [&](int64_t begin, int64_t end) {
    for (int64_t pn = begin; pn < end; ++pn) skin_point(a, pn);
  });
}

template void grid_forward_skinning_cpu<float>(const SkinningLaunch<float>&);
template void grid_forward_skinning_cpu<double>(const SkinningLaunch<double>&);

}  // namespace fskin::grid_skinning
