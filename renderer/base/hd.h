// CAUSTICA_HD marks code that runs on both backends: __host__ __device__ under nvcc, nothing
// under a host compiler. Per-element work (kernels' bodies, math, traversal) is written once with
// it, in the style of pbrt-v4.
#pragma once

#if defined(__CUDACC__)
#define CAUSTICA_HD __host__ __device__
#define CAUSTICA_INLINE __forceinline__
#else
#define CAUSTICA_HD
#define CAUSTICA_INLINE inline
#endif

#define CAUSTICA_HDI CAUSTICA_HD CAUSTICA_INLINE
