// CPU kernel of the ray compositing: at::parallel_for over rays.
#include <ATen/Parallel.h>

#include "ops/ray_compositing/ray_compositing_kernel.h"

namespace fskin::ray_compositing {

template <typename T>
void composite_rays_cpu(const CompositeLaunch<T>& a, bool backward) {
  at::parallel_for(0, a.rays, 256, [&](int64_t begin, int64_t end) {
    for (int64_t r = begin; r < end; ++r) {
      if (backward) {
        composite_ray_backward(a, r);
      } else {
        composite_ray(a, r);
      }
    }
  });
}

template void composite_rays_cpu<float>(const CompositeLaunch<float>&, bool);
template void composite_rays_cpu<double>(const CompositeLaunch<double>&, bool);

}  // namespace fskin::ray_compositing
