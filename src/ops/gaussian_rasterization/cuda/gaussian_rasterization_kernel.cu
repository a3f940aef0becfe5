// CUDA kernel of the Gaussian rasterisation: a 16 x 16 thread block per tile,
// a thread per pixel, reading the tile's list from global memory (no shared-
// memory staging yet). The backward accumulates per-Gaussian gradients with
// atomicAdd, so float sums vary in their last bits from run to run, as in
// other CUDA rasterisers. Raw pointers only, no LibTorch headers.
#include "ops/common/cuda_launch.cuh"
#include "ops/gaussian_rasterization/gaussian_rasterization_kernel.h"

namespace fskin::gaussian_rasterization {
namespace {

template <typename T>
__global__ void rasterize_kernel(const RasterLaunch<T> a, bool backward) {
  const int x = blockIdx.x * kTileSize + threadIdx.x;
  const int y = blockIdx.y * kTileSize + threadIdx.y;
  if (x >= a.width || y >= a.height) return;
  const int64_t tile = static_cast<int64_t>(blockIdx.y) * a.tiles_x + blockIdx.x;
  const int64_t begin = a.tile_ranges[tile], end = a.tile_ranges[tile + 1];
  if (backward) {
    const int columns = gradient_columns(a.channels);
    rasterize_pixel_backward(a, begin, end, x, y, [&](int64_t, int64_t gaussian, int column, T value) {
      atomicAdd(a.grad_rows + gaussian * columns + column, value);
    });
  } else {
    rasterize_pixel(a, begin, end, x, y);
  }
}

}  // namespace

template <typename T>
void rasterize_cuda(const RasterLaunch<T>& launch, bool backward, void* stream) {
  if (launch.tiles_x <= 0 || launch.tiles_y <= 0) return;
  const dim3 blocks(static_cast<unsigned>(launch.tiles_x), static_cast<unsigned>(launch.tiles_y));
  const dim3 threads(kTileSize, kTileSize);
  rasterize_kernel<T><<<blocks, threads, 0, static_cast<cudaStream_t>(stream)>>>(launch, backward);
  const cudaError_t err = cudaGetLastError();
  if (err != cudaSuccess) {
    throw Error(std::string(backward ? "rasterize_gaussians backward" : "rasterize_gaussians") +
                ": CUDA kernel launch failed: " + cudaGetErrorString(err));
  }
}

template void rasterize_cuda<float>(const RasterLaunch<float>&, bool, void*);
template void rasterize_cuda<double>(const RasterLaunch<double>&, bool, void*);

}  // namespace fskin::gaussian_rasterization
