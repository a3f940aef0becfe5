#pragma once
// Functions the CPU and CUDA kernels share are inline on the host and
// __host__ __device__ under nvcc, so both compile the very same code.
#if defined(__CUDACC__)
#define FSKIN_HOST_DEVICE __host__ __device__ __forceinline__
#else
#define FSKIN_HOST_DEVICE inline
#endif
