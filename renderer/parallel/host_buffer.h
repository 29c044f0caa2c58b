// HostBuffer<T>: host memory that a backend copies device results into, page-locked on a GPU
// (Backend::allocate_host), kept from one frame to the next so that each frame's image comes back
// by one direct copy into memory already mapped.
#pragma once

#include <span>

#include "renderer/parallel/backend_array.h"

namespace caustica {

template <typename T>
class HostBuffer : public BackendArray<T, HostMemory> {
 public:
  using BackendArray<T, HostMemory>::BackendArray;

  std::span<const T> span() const { return {this->data(), this->size()}; }
};

}  // namespace caustica
