// The backend: memory, copies and the whole-array primitives every builder reduces to (Zeidan
// 2011 ch. 3: sort, scan, reduce, compact, run-length). Per-element work goes through
// parallel_for (parallel_for.h). Implementations: cpu/ (oneTBB) and cuda/ (CUB).
//
// Pointers handed to a backend are its own memory (Buffer<T>::data()); on CUDA they are device
// pointers, so renderer code never dereferences them on the host.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "absl/status/statusor.h"
#include "renderer/base/aabb.h"

namespace caustica {

enum class DeviceKind { kCpu, kCuda };

// Thrown by allocations beyond the backend's byte budget; the engine converts it into
// RESOURCE_EXHAUSTED at its border, so no exception leaves the renderer library.
class BudgetExceeded : public std::bad_alloc {
 public:
  BudgetExceeded(size_t requested, size_t in_use, size_t budget);
  const char* what() const noexcept override { return message_.c_str(); }

 private:
  std::string message_;
};

// Thrown when the device has no memory left for an allocation within the budget (the budget is
// larger than what is free); RESOURCE_EXHAUSTED at the engine's border, as a budget overrun is.
class OutOfDeviceMemory : public std::bad_alloc {
 public:
  OutOfDeviceMemory(size_t requested, size_t in_use);
  const char* what() const noexcept override { return message_.c_str(); }

 private:
  std::string message_;
};

// The environment variable that makes every allocation of more than its value in bytes fail as
// if the device were out of memory: a fault-injection hook for tests of what a real device
// failure does to a running server (docs/reliability.md).
inline constexpr char kFailAllocationsAboveVariable[] = "CAUSTICA_FAIL_ALLOCATIONS_ABOVE";

// Thrown when the device itself fails (a CUDA call returns an error); the engine converts it into
// INTERNAL at its border.
class DeviceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct DeviceInfo {
  std::string name;
  int compute_units = 0;    // CPU threads or CUDA SMs
  size_t memory_bytes = 0;  // physical memory of the device
  int ordinal = 0;          // the CUDA device number; 0 on the CPU
};

// What the launch profiler gathered for one launch name (Backend::launch_times).
struct LaunchTime {
  std::string name;
  uint64_t launches = 0;
  double total_ms = 0;
};

class Backend {
 public:
  explicit Backend(size_t memory_budget_bytes);
  virtual ~Backend() = default;
  Backend(const Backend&) = delete;
  Backend& operator=(const Backend&) = delete;

  virtual DeviceKind kind() const = 0;
  virtual DeviceInfo info() const = 0;

  // --- memory (counted against the budget; safe to call from any thread, since engines that
  // share a backend may free a scene while another renders) ---
  void* allocate(size_t bytes);
  void deallocate(void* p, size_t bytes);
  size_t bytes_in_use() const {
    std::lock_guard<std::mutex> lock(memory_mutex_);
    return in_use_;
  }
  size_t peak_bytes() const {
    std::lock_guard<std::mutex> lock(memory_mutex_);
    return peak_;
  }
  size_t budget() const { return budget_; }

  // Host memory for what comes back from the device every frame (the image): page-locked on a
  // GPU, so that copies into it run at the bus's rate without the driver staging them through
  // its own buffer; ordinary memory on the CPU. Not counted against the budget, which is the
  // device's. Freeing may wait for the device.
  virtual void* allocate_host(size_t bytes) = 0;
  virtual void deallocate_host(void* p) noexcept = 0;

  virtual void copy_to_device(void* dst, const void* src, size_t bytes) = 0;
  virtual void copy_to_host(void* dst, const void* src, size_t bytes) = 0;
  virtual void copy_on_device(void* dst, const void* src, size_t bytes) = 0;
  virtual void fill_bytes(void* dst, uint8_t value, size_t bytes) = 0;
  // Copies `bytes` of `source`'s memory at `src` into this backend's at `dst`: device to device
  // where both are GPUs (over the peer link where there is one), else through the host. The
  // caller synchronises `source` first, and keeps `src` until this backend synchronises.
  virtual void copy_from(Backend& source, void* dst, const void* src, size_t bytes);
  virtual void synchronize() = 0;
  // Makes this backend's device the calling thread's current one: a thread that works on several
  // GPUs calls it before each one's work. Nothing to do on the CPU.
  virtual void make_current() {}
  // Milliseconds the device spends on the work `fn` queues, for benchmarks: host clock around
  // synchronisations here, CUDA events on the backend's stream in the CUDA backend.
  virtual double time_ms(const std::function<void()>& fn);

  // --- primitives ---
  // Stable ascending key-value radix sort on the key bits [0, end_bit), in place.
  virtual void sort_pairs(uint32_t* keys, uint32_t* values, size_t n, int end_bit = 32) = 0;
  virtual void sort_pairs(uint64_t* keys, uint32_t* values, size_t n, int end_bit = 64) = 0;
  // out[i] = sum of in[0..i); `in` and `out` may alias. Returns the total of all n inputs.
  virtual uint32_t exclusive_scan(const uint32_t* in, uint32_t* out, size_t n) = 0;
  virtual float exclusive_scan(const float* in, float* out, size_t n) = 0;
  virtual uint64_t reduce_sum(const uint32_t* in, size_t n) = 0;
  virtual double reduce_sum(const float* in, size_t n) = 0;
  virtual float reduce_max(const float* in, size_t n) = 0;
  virtual Aabb reduce_bounds(const Aabb* in, size_t n) = 0;
  // The same reduction written to `out` (one Aabb in the backend's memory) without waiting for
  // it, for a build whose next kernel reads it: no round trip to the host in between.
  virtual void reduce_bounds_to(const Aabb* in, size_t n, Aabb* out) = 0;
  // Writes, in order, the in[i] whose flags[i] != 0 to `out`; returns how many. With in == nullptr
  // the selected indices i themselves are written (the gather step of a compaction).
  virtual size_t select_flagged(const uint32_t* in, const uint8_t* flags, size_t n,
                                uint32_t* out) = 0;
  // Collapses runs of equal consecutive keys: unique_out[r] is the r-th run's key, counts_out[r]
  // its length. Returns the number of runs.
  virtual size_t run_length_encode(const uint32_t* in, size_t n, uint32_t* unique_out,
                                   uint32_t* counts_out) = 0;

  // --- launch timing (opt-in, off by default) ---
  // While on, every parallel_for and primitive adds its time to a table by launch name: the host
  // clock around the loop on the CPU, a pair of CUDA events around the kernel on the GPU. While
  // off, a launch pays one branch for it. Turning it off keeps what was gathered.
  void set_launch_timing(bool enabled) { launch_timing_.store(enabled, std::memory_order_relaxed); }
  bool launch_timing() const { return launch_timing_.load(std::memory_order_relaxed); }
  // Launches and milliseconds summed per name, the most time first. Waits for the device, whose
  // event times are read only here, so that timing adds no synchronisation to the launches.
  std::vector<LaunchTime> launch_times();
  void clear_launch_times();

  // The two ends of one launch named `name` (a string literal), for parallel_for and the backends'
  // primitives while launch_timing() is on; the mark launch_began returns goes to launch_ended.
  // `launched` false: nothing ran after all (no room for a launch's scratch), nothing is counted.
  // The base class times with the host clock, the CPU's launches being done when they return.
  virtual uint64_t launch_began(const char* name);
  virtual void launch_ended(const char* name, uint64_t mark, bool launched = true);

  // Runs `launch()` as the launch `name`, bracketed by launch_began and launch_ended while
  // launch timing is on; returns what it returns.
  template <typename Launch>
  decltype(auto) timed_launch(const char* name, Launch&& launch) {
    if (launch_timing()) [[unlikely]] {
      const uint64_t mark = launch_began(name);
      if constexpr (std::is_void_v<decltype(launch())>) {
        launch();
        launch_ended(name, mark);
        return;
      } else {
        auto result = launch();
        launch_ended(name, mark);
        return result;
      }
    }
    return launch();
  }

 protected:
  virtual void* allocate_raw(size_t bytes) = 0;
  virtual void deallocate_raw(void* p, size_t bytes) = 0;

  // Adds `launches` launches of `name` taking `ms` in all to the table.
  void add_launch_time(const char* name, uint64_t launches, double ms);
  // Brings times still on the device into the table (add_launch_time); the CUDA backend's events.
  virtual void collect_launch_times() {}

 private:
  size_t budget_;
  size_t fail_above_ = 0;  // kFailAllocationsAboveVariable's value; 0: off
  mutable std::mutex memory_mutex_;
  size_t in_use_ = 0;
  size_t peak_ = 0;

  // Launches on one backend come from one thread at a time (its engine's or a benchmark's), so
  // the lock is uncontended; it is there for launch_times() read from another thread, and is
  // taken only while timing is on.
  std::atomic<bool> launch_timing_{false};
  std::mutex launch_times_mutex_;
  std::map<std::string, LaunchTime, std::less<>> launch_table_;
};

// The CPU backend on oneTBB, using every core TBB is allowed.
std::unique_ptr<Backend> make_cpu_backend(size_t memory_budget_bytes);

}  // namespace caustica
