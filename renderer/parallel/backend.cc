#include "renderer/parallel/backend.h"

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "absl/strings/str_format.h"

namespace caustica {

BudgetExceeded::BudgetExceeded(size_t requested, size_t in_use, size_t budget)
    : message_(
          absl::StrFormat("memory budget exceeded: %d bytes requested with %d of %d bytes in use",
                          requested, in_use, budget)) {}

OutOfDeviceMemory::OutOfDeviceMemory(size_t requested, size_t in_use)
    : message_(absl::StrFormat(
          "the device is out of memory: %d bytes requested with %d in use (within the budget)",
          requested, in_use)) {}

Backend::Backend(size_t memory_budget_bytes) : budget_(memory_budget_bytes) {
  if (const char* above = std::getenv(kFailAllocationsAboveVariable); above != nullptr)
    fail_above_ = std::strtoull(above, nullptr, 10);
}

void* Backend::allocate(size_t bytes) {
  if (bytes == 0) return nullptr;
  std::lock_guard<std::mutex> lock(memory_mutex_);
  if (bytes > budget_ || in_use_ > budget_ - bytes) throw BudgetExceeded(bytes, in_use_, budget_);
  if (fail_above_ > 0 && bytes > fail_above_) throw OutOfDeviceMemory(bytes, in_use_);
  void* p;
  try {
    p = allocate_raw(bytes);
  } catch (const std::bad_alloc&) {
    throw OutOfDeviceMemory(bytes, in_use_);
  }
  in_use_ += bytes;
  peak_ = std::max(peak_, in_use_);
  return p;
}

void Backend::deallocate(void* p, size_t bytes) {
  if (p == nullptr) return;
  std::lock_guard<std::mutex> lock(memory_mutex_);
  deallocate_raw(p, bytes);
  in_use_ -= bytes;
}

void Backend::copy_from(Backend& source, void* dst, const void* src, size_t bytes) {
  if (bytes == 0) return;
  // A CPU backend's memory is the host's, so one copy does where either side is the CPU.
  if (source.kind() == DeviceKind::kCpu) {
    copy_to_device(dst, src, bytes);
  } else if (kind() == DeviceKind::kCpu) {
    source.copy_to_host(dst, src, bytes);
  } else {
    std::vector<std::byte> staging(bytes);
    source.copy_to_host(staging.data(), src, bytes);
    copy_to_device(dst, staging.data(), bytes);
  }
}

double Backend::time_ms(const std::function<void()>& fn) {
  synchronize();
  const auto start = std::chrono::steady_clock::now();
  fn();
  synchronize();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// The mark is the start on the host clock, in the clock's ticks.
uint64_t Backend::launch_began(const char*) {
  return uint64_t(std::chrono::steady_clock::now().time_since_epoch().count());
}

void Backend::launch_ended(const char* name, uint64_t mark, bool launched) {
  if (!launched) return;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start{Clock::duration(Clock::rep(mark))};
  add_launch_time(name, 1, std::chrono::duration<double, std::milli>(Clock::now() - start).count());
}

void Backend::add_launch_time(const char* name, uint64_t launches, double ms) {
  std::lock_guard<std::mutex> lock(launch_times_mutex_);
  auto it = launch_table_.find(std::string_view(name));
  if (it == launch_table_.end()) it = launch_table_.emplace(name, LaunchTime{name, 0, 0.0}).first;
  it->second.launches += launches;
  it->second.total_ms += ms;
}

std::vector<LaunchTime> Backend::launch_times() {
  collect_launch_times();
  std::vector<LaunchTime> times;
  {
    std::lock_guard<std::mutex> lock(launch_times_mutex_);
    for (const auto& [name, time] : launch_table_) times.push_back(time);
  }
  std::stable_sort(times.begin(), times.end(), [](const LaunchTime& a, const LaunchTime& b) {
    return a.total_ms > b.total_ms;
  });
  return times;
}

void Backend::clear_launch_times() {
  // Times still on the device belong to launches before the clear.
  collect_launch_times();
  std::lock_guard<std::mutex> lock(launch_times_mutex_);
  launch_table_.clear();
}

}  // namespace caustica
