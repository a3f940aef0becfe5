#pragma once
// Functions the CPU and CUDA kernels share are inline on the host and
// __host__ __device__ under nvcc, so both compile the very same code.
#if defined(__CUDACC__)
#define FSKIN_HOST_DEVICE __host__ __device__ __forceinline__
#else
#define FSKIN_HOST_DEVICE inline
#endif

// For the solver's per-lane steps inside the CPU kernels' lane loops: forced
// inline, the fused search runs at the speed of its hand-inlined loop
// (docs/benchmarks.md, "One Broyden solver"); without it GCC may keep them out of line.
#if defined(__CUDACC__)
#define FSKIN_HOST_DEVICE_INLINE __host__ __device__ __forceinline__
#elif defined(__GNUC__)
#define FSKIN_HOST_DEVICE_INLINE inline __attribute__((always_inline))
#else
#define FSKIN_HOST_DEVICE_INLINE inline
#endif
