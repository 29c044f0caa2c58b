// BackendArray<T, Memory>: what Buffer (device memory, buffer.h) and HostBuffer (page-locked host
// memory, host_buffer.h) share: a typed array a backend allocates through `Memory`, move-only,
// grown by resize_discard and never shrunk.
#pragma once

#include <cstddef>
#include <type_traits>
#include <utility>

#include "renderer/parallel/backend.h"

namespace caustica {

// The backend's own memory: device memory on CUDA, counted against the budget.
struct DeviceMemory {
  static void* allocate(Backend& b, size_t bytes) { return b.allocate(bytes); }
  static void release(Backend& b, void* p, size_t bytes) { b.deallocate(p, bytes); }
};

// Host memory for results that come back every frame: page-locked on CUDA.
struct HostMemory {
  static void* allocate(Backend& b, size_t bytes) { return b.allocate_host(bytes); }
  static void release(Backend& b, void* p, size_t) { b.deallocate_host(p); }
};

template <typename T, typename Memory>
class BackendArray {
  static_assert(std::is_trivially_copyable_v<T>, "backend arrays hold plain data");

 public:
  BackendArray() = default;
  explicit BackendArray(Backend& backend) : backend_(&backend) {}
  ~BackendArray() { release(); }
  BackendArray(BackendArray&& o) noexcept { *this = std::move(o); }
  BackendArray& operator=(BackendArray&& o) noexcept {
    if (this != &o) {
      release();
      backend_ = std::exchange(o.backend_, nullptr);
      data_ = std::exchange(o.data_, nullptr);
      size_ = std::exchange(o.size_, 0);
      capacity_ = std::exchange(o.capacity_, 0);
    }
    return *this;
  }
  BackendArray(const BackendArray&) = delete;
  BackendArray& operator=(const BackendArray&) = delete;

  void bind(Backend& backend) {
    release();
    backend_ = &backend;
  }
  // Sets the size; old contents are not preserved when the array has to grow.
  void resize_discard(size_t size) {
    if (size > capacity_) {
      Backend* b = backend_;
      release();
      backend_ = b;
      data_ = static_cast<T*>(Memory::allocate(*backend_, size * sizeof(T)));
      capacity_ = size;
    }
    size_ = size;
  }

  T* data() { return data_; }
  const T* data() const { return data_; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  size_t bytes() const { return capacity_ * sizeof(T); }
  Backend* backend() const { return backend_; }

 private:
  void release() {
    if (backend_ != nullptr && data_ != nullptr)
      Memory::release(*backend_, data_, capacity_ * sizeof(T));
    data_ = nullptr;
    size_ = capacity_ = 0;
  }

  Backend* backend_ = nullptr;
  T* data_ = nullptr;
  size_t size_ = 0;
  size_t capacity_ = 0;
};

}  // namespace caustica
