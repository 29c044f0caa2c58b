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

// Loop unrolling on a GPU: NO_UNROLL keeps a short loop rolled where unrolling would copy a large
// inlined body; UNROLL_BY(n) lets n iterations' loads be in flight together.
#if defined(__CUDA_ARCH__)
#define CAUSTICA_NO_UNROLL _Pragma("unroll 1")
#define CAUSTICA_PRAGMA(x) _Pragma(#x)
#define CAUSTICA_UNROLL_BY(n) CAUSTICA_PRAGMA(unroll n)
#else
#define CAUSTICA_NO_UNROLL
#define CAUSTICA_UNROLL_BY(n)
#endif
