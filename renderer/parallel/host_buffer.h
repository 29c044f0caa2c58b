// HostBuffer<T>: host memory that a backend copies device results into, page-locked on a GPU
// (Backend::allocate_host), kept from one frame to the next so that each frame's image comes back
// by one direct copy into memory already mapped. Grows, never shrinks; move-only.
#pragma once

#include <span>
#include <type_traits>
#include <utility>

#include "renderer/parallel/backend.h"

namespace caustica {

template <typename T>
class HostBuffer {
  static_assert(std::is_trivially_copyable_v<T>, "host buffers hold plain data");

 public:
  HostBuffer() = default;
  explicit HostBuffer(Backend& backend) : backend_(&backend) {}
  ~HostBuffer() { release(); }
  HostBuffer(HostBuffer&& o) noexcept { *this = std::move(o); }
  HostBuffer& operator=(HostBuffer&& o) noexcept {
    if (this != &o) {
      release();
      backend_ = std::exchange(o.backend_, nullptr);
      data_ = std::exchange(o.data_, nullptr);
      size_ = std::exchange(o.size_, 0);
      capacity_ = std::exchange(o.capacity_, 0);
    }
    return *this;
  }
  HostBuffer(const HostBuffer&) = delete;
  HostBuffer& operator=(const HostBuffer&) = delete;

  // Sets the size; old contents are not preserved when the buffer has to grow.
  void resize_discard(size_t size) {
    if (size > capacity_) {
      Backend* b = backend_;
      release();
      backend_ = b;
      data_ = static_cast<T*>(backend_->allocate_host(size * sizeof(T)));
      capacity_ = size;
    }
    size_ = size;
  }

  T* data() { return data_; }
  size_t size() const { return size_; }
  std::span<const T> span() const { return {data_, size_}; }

 private:
  void release() noexcept {
    if (backend_ != nullptr && data_ != nullptr) backend_->deallocate_host(data_);
    data_ = nullptr;
    size_ = capacity_ = 0;
  }

  Backend* backend_ = nullptr;
  T* data_ = nullptr;
  size_t size_ = 0, capacity_ = 0;
};

}  // namespace caustica
