#include "server/device_queue.h"

#include <algorithm>
#include <utility>

namespace caustica::server {
namespace {

// How often a waiter re-checks its StopCheck; gRPC has no wake-up for cancellation here.
constexpr auto kStopPollInterval = std::chrono::milliseconds(20);

}  // namespace

DeviceQueue::Lease::Lease(Lease&& other) noexcept
    : queue_(std::exchange(other.queue_, nullptr)), waited_ms_(other.waited_ms_) {}

DeviceQueue::Lease& DeviceQueue::Lease::operator=(Lease&& other) noexcept {
  if (this != &other) {
    release();
    queue_ = std::exchange(other.queue_, nullptr);
    waited_ms_ = other.waited_ms_;
  }
  return *this;
}

DeviceQueue::Lease::~Lease() { release(); }

void DeviceQueue::Lease::release() {
  if (queue_ != nullptr) std::exchange(queue_, nullptr)->release_device();
}

absl::StatusOr<DeviceQueue::Lease> DeviceQueue::acquire(const StopCheck& stop) {
  const auto start = std::chrono::steady_clock::now();
  std::unique_lock<std::mutex> lock(mutex_);
  if (shut_down_) return absl::UnavailableError("the server is shutting down");
  Waiter me;
  line_.push_back(&me);
  auto leave_line = [&] {
    const bool was_front = line_.front() == &me;
    line_.erase(std::find(line_.begin(), line_.end(), &me));
    if (was_front) wake_front_locked();
  };
  while (busy_ || line_.front() != &me) {
    if (shut_down_) {
      leave_line();
      return absl::UnavailableError("the server is shutting down");
    }
    if (stop) {
      lock.unlock();
      absl::Status status = stop();
      lock.lock();
      if (!status.ok()) {
        leave_line();
        return status;
      }
    }
    me.wake.wait_for(lock, kStopPollInterval);
  }
  line_.pop_front();
  busy_ = true;
  const double waited =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return Lease(this, waited);
}

void DeviceQueue::wake_front_locked() {
  // Only the front can take the device; waking the others too would have every waiter of a long
  // line contend for the mutex at every release.
  if (!busy_ && !line_.empty()) line_.front()->wake.notify_one();
}

void DeviceQueue::release_device() {
  std::lock_guard<std::mutex> lock(mutex_);
  busy_ = false;
  wake_front_locked();
}

void DeviceQueue::shut_down() {
  std::lock_guard<std::mutex> lock(mutex_);
  shut_down_ = true;
  for (Waiter* waiter : line_) waiter->wake.notify_one();
}

size_t DeviceQueue::waiting() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return line_.size();
}

}  // namespace caustica::server
