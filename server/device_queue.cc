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
  const uint64_t ticket = next_ticket_++;
  line_.push_back(ticket);
  auto leave_line = [&] {
    line_.erase(std::find(line_.begin(), line_.end(), ticket));
    // The next waiter may now be at the front.
    changed_.notify_all();
  };
  while (busy_ || line_.front() != ticket) {
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
    changed_.wait_for(lock, kStopPollInterval);
  }
  line_.pop_front();
  busy_ = true;
  const double waited =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return Lease(this, waited);
}

void DeviceQueue::release_device() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    busy_ = false;
  }
  changed_.notify_all();
}

void DeviceQueue::shut_down() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shut_down_ = true;
  }
  changed_.notify_all();
}

size_t DeviceQueue::waiting() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return line_.size();
}

}  // namespace caustica::server
