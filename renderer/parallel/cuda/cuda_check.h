// CAUSTICA_CUDA_CHECK: every CUDA runtime call goes through it, so a failure surfaces at once as a
// DeviceError naming the call, its file:line and CUDA's message, instead of as wrong results or
// a later, unrelated error (CUDA errors are sticky and asynchronous).
#pragma once

#include <cuda_runtime_api.h>

#include "renderer/parallel/backend.h"

namespace caustica {

// Throws DeviceError("file:line: expression: cudaErrorName: description").
[[noreturn]] void throw_cuda_error(cudaError_t status, const char* expression, const char* file,
                                   int line);

}  // namespace caustica

#define CAUSTICA_CUDA_CHECK(expression)                                                     \
  do {                                                                                      \
    const cudaError_t caustica_cuda_status_ = (expression);                                 \
    if (caustica_cuda_status_ != cudaSuccess)                                               \
      ::caustica::throw_cuda_error(caustica_cuda_status_, #expression, __FILE__, __LINE__); \
  } while (false)
