// Fair access to one device, which the scenes placed there share (the server has one queue per
// device). Work takes a Lease, holds it for one unit (one render pass, one upload build, one
// rebuild, one resolve) and gives it back; waiters are served first come, first served. A render
// job re-queues for every pass, so concurrent clients interleave pass by pass instead of one long
// job starving the others. Holding the lease is also what serialises every engine call on the
// device: engines there share one Backend and are not thread-safe.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>

#include "absl/status/statusor.h"

namespace caustica::server {

class DeviceQueue {
 public:
  // While held, the device is this caller's alone. Movable; releasing hands the device to the
  // next waiter in line.
  class Lease {
   public:
    Lease() = default;
    Lease(Lease&& other) noexcept;
    Lease& operator=(Lease&& other) noexcept;
    ~Lease();
    void release();
    bool held() const { return queue_ != nullptr; }
    double waited_ms() const { return waited_ms_; }  // time spent in the queue

   private:
    friend class DeviceQueue;
    Lease(DeviceQueue* queue, double waited_ms) : queue_(queue), waited_ms_(waited_ms) {}
    DeviceQueue* queue_ = nullptr;
    double waited_ms_ = 0;
  };

  // Polled while waiting; a non-OK status (the caller's CANCELLED or DEADLINE_EXCEEDED) gives up
  // the place in line and is returned.
  using StopCheck = std::function<absl::Status()>;

  // Waits for the device behind everyone already waiting. UNAVAILABLE once shut down.
  absl::StatusOr<Lease> acquire(const StopCheck& stop = {});

  // Wakes every waiter with UNAVAILABLE and refuses later acquires; held leases stay valid.
  void shut_down();

  size_t waiting() const;

 private:
  // One waiter in line, on its own stack; woken alone when it reaches the front.
  struct Waiter {
    std::condition_variable wake;
  };
  void release_device();
  void wake_front_locked();

  mutable std::mutex mutex_;
  std::deque<Waiter*> line_;  // in arrival order
  bool busy_ = false;
  bool shut_down_ = false;
};

}  // namespace caustica::server
