// Buffer<T>: a typed array owned by a backend (host memory on the CPU backend, device memory on
// CUDA). Move-only; contents cross to the host only through upload()/download().
#pragma once

#include <span>
#include <vector>

#include "renderer/parallel/backend_array.h"
#include "renderer/parallel/host_buffer.h"

namespace caustica {

template <typename T>
class Buffer : public BackendArray<T, DeviceMemory> {
 public:
  Buffer() = default;
  Buffer(Backend& backend, size_t size) : BackendArray<T, DeviceMemory>(backend) {
    this->resize_discard(size);
  }

  void upload(std::span<const T> host) {
    this->resize_discard(host.size());
    if (!host.empty())
      this->backend()->copy_to_device(this->data(), host.data(), host.size_bytes());
  }
  std::vector<T> download() const {
    std::vector<T> host(this->size());
    if (!this->empty())
      this->backend()->copy_to_host(host.data(), this->data(), this->size() * sizeof(T));
    return host;
  }
  // Into `host`, resized to match: for what comes back every frame (host_buffer.h).
  std::span<const T> download(HostBuffer<T>& host) const {
    host.resize_discard(this->size());
    if (!this->empty())
      this->backend()->copy_to_host(host.data(), this->data(), this->size() * sizeof(T));
    return host.span();
  }
  void fill_zero() {
    if (!this->empty()) this->backend()->fill_bytes(this->data(), 0, this->size() * sizeof(T));
  }
};

}  // namespace caustica
