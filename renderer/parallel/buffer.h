// Buffer<T>: a typed array owned by a backend (host memory on the CPU backend, device memory on
// CUDA). Move-only; contents cross to the host only through upload()/download().
#pragma once

#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include "renderer/parallel/backend.h"
#include "renderer/parallel/host_buffer.h"

namespace caustica {

template <typename T>
class Buffer {
  static_assert(std::is_trivially_copyable_v<T>, "buffers hold plain data");

 public:
  Buffer() = default;
  Buffer(Backend& backend, size_t size) : backend_(&backend) { resize_discard(size); }
  ~Buffer() { release(); }
  Buffer(Buffer&& o) noexcept { *this = std::move(o); }
  Buffer& operator=(Buffer&& o) noexcept {
    if (this != &o) {
      release();
      backend_ = std::exchange(o.backend_, nullptr);
      data_ = std::exchange(o.data_, nullptr);
      size_ = std::exchange(o.size_, 0);
      capacity_ = std::exchange(o.capacity_, 0);
    }
    return *this;
  }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  void bind(Backend& backend) {
    release();
    backend_ = &backend;
  }
  // Sets the size; old contents are not preserved when the buffer has to grow.
  void resize_discard(size_t size) {
    if (size > capacity_) {
      Backend* b = backend_;
      release();
      backend_ = b;
      data_ = static_cast<T*>(backend_->allocate(size * sizeof(T)));
      capacity_ = size;
    }
    size_ = size;
  }
  void upload(std::span<const T> host) {
    resize_discard(host.size());
    if (!host.empty()) backend_->copy_to_device(data_, host.data(), host.size_bytes());
  }
  std::vector<T> download() const {
    std::vector<T> host(size_);
    if (size_ > 0) backend_->copy_to_host(host.data(), data_, size_ * sizeof(T));
    return host;
  }
  // Into `host`, resized to match: for what comes back every frame (host_buffer.h).
  std::span<const T> download(HostBuffer<T>& host) const {
    host.resize_discard(size_);
    if (size_ > 0) backend_->copy_to_host(host.data(), data_, size_ * sizeof(T));
    return host.span();
  }
  void fill_zero() {
    if (size_ > 0) backend_->fill_bytes(data_, 0, size_ * sizeof(T));
  }

  T* data() { return data_; }
  const T* data() const { return data_; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  size_t bytes() const { return capacity_ * sizeof(T); }
  Backend* backend() const { return backend_; }

 private:
  void release() {
    if (backend_ != nullptr && data_ != nullptr) backend_->deallocate(data_, capacity_ * sizeof(T));
    data_ = nullptr;
    size_ = capacity_ = 0;
  }

  Backend* backend_ = nullptr;
  T* data_ = nullptr;
  size_t size_ = 0;
  size_t capacity_ = 0;
};

}  // namespace caustica
