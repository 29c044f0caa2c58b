// The CUDA backend's entry points, free of CUDA headers so that host-compiled code (the engine,
// tests) can offer it. Defined only in builds with CAUSTICA_CUDA (CAUSTICA_WITH_CUDA is set).
#pragma once

#include <cstddef>
#include <memory>

#include "renderer/parallel/backend.h"

namespace caustica {

// True when the CUDA runtime finds a driver and at least one GPU. Never throws.
bool cuda_device_available();

// The GPUs the CUDA runtime sees (0 without a driver). Never throws.
int cuda_device_count();

// A backend on CUDA device `ordinal` (-1: the calling thread's current one): its own non-blocking
// stream, allocations from its own stream-ordered pool counted against `memory_budget_bytes`,
// primitives on CUB. Throws DeviceError when no device can be used.
std::unique_ptr<Backend> make_cuda_backend(size_t memory_budget_bytes, int ordinal = -1);

}  // namespace caustica
