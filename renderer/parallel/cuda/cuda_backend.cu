// CUDA backend: the primitive layer on CUB, all work ordered on one non-blocking stream per
// backend, memory from a stream-ordered pool (cudaMallocFromPoolAsync) that keeps freed blocks
// for reuse, CUB's temporary storage included, so every byte counts against the budget.
//
// Where it differs from the CPU backend (cpu/cpu_backend.cc):
// - exclusive_scan(float) accumulates in double as the CPU does, but in another order (CUB's
//   tiles instead of chunks), so results agree to a few float ulps, not bit for bit;
// - reduce_sum(float) likewise sums in double in another order;
// - run_length_encode takes at most 2^31 - 1 keys (CUB's limit); more throws DeviceError.
// The sorts (stable LSD radix sorts of the same key bits), integer scans and sums, max, bounds,
// selection and run-length encoding give identical results.
#include <cuda_runtime_api.h>
#include <thrust/iterator/counting_iterator.h>
#include <thrust/iterator/tabulate_output_iterator.h>
#include <thrust/iterator/transform_iterator.h>

#include <cfloat>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_run_length_encode.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/device/device_select.cuh>
#include <cuda/std/functional>
#include <mutex>
#include <new>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "renderer/base/aabb.h"
#include "renderer/parallel/buffer.h"
#include "renderer/parallel/cuda/cuda_backend.h"
#include "renderer/parallel/cuda/launch.cuh"

namespace caustica {

void throw_cuda_error(cudaError_t status, const char* expression, const char* file, int line) {
  throw DeviceError(absl::StrFormat("%s:%d: %s: %s: %s", file, line, expression,
                                    cudaGetErrorName(status), cudaGetErrorString(status)));
}

namespace {

// For paths that must not throw (frees, destructors): the error is reported, not lost.
void log_cuda_error(cudaError_t status, const char* expression, const char* file,
                    int line) noexcept {
  if (status == cudaSuccess) return;
  std::fprintf(stderr, "caustica: %s:%d: %s: %s: %s\n", file, line, expression,
               cudaGetErrorName(status), cudaGetErrorString(status));
}
#define CAUSTICA_CUDA_LOG(expression) log_cuda_error((expression), #expression, __FILE__, __LINE__)

// Exclusive scans run over n + 1 items: the n inputs in the accumulator type, then a zero, so that
// output n is the total and no input has to be read before the scan (the scan may be in place).
template <typename T, typename Acc>
struct ScanInput {
  const T* in;
  size_t n;
  __host__ __device__ Acc operator()(size_t i) const { return i < n ? Acc(in[i]) : Acc(0); }
};

// Receives output i of the scan: out[i] for i < n, the total for i == n.
template <typename T, typename Acc>
struct ScanOutput {
  T* out;
  size_t n;
  Acc* total;
  __host__ __device__ void operator()(ptrdiff_t i, Acc v) const {
    if (size_t(i) < n) {
      out[i] = T(v);
    } else {
      *total = v;
    }
  }
};

struct MaxOp {
  __host__ __device__ float operator()(float a, float b) const { return max_f(a, b); }
};

struct MergeBoundsOp {
  __host__ __device__ Aabb operator()(const Aabb& a, const Aabb& b) const { return merge(a, b); }
};

// Makes `device` current for a scope and the caller's device again after it: memory may be
// allocated and freed from any thread (a scene deleted while another device renders).
class DeviceScope {
 public:
  explicit DeviceScope(int device) {
    if (cudaGetDevice(&previous_) == cudaSuccess && previous_ != device) {
      CAUSTICA_CUDA_LOG(cudaSetDevice(device));
    } else {
      previous_ = -1;
    }
  }
  ~DeviceScope() {
    if (previous_ >= 0) CAUSTICA_CUDA_LOG(cudaSetDevice(previous_));
  }
  DeviceScope(const DeviceScope&) = delete;
  DeviceScope& operator=(const DeviceScope&) = delete;

 private:
  int previous_ = -1;
};

class CudaBackend final : public Backend {
 public:
  CudaBackend(size_t memory_budget_bytes, int ordinal) : Backend(memory_budget_bytes) {
    try {
      if (ordinal >= 0) CAUSTICA_CUDA_CHECK(cudaSetDevice(ordinal));
      CAUSTICA_CUDA_CHECK(cudaGetDevice(&device_));
      cudaDeviceProp prop;
      CAUSTICA_CUDA_CHECK(cudaGetDeviceProperties(&prop, device_));
      info_ = {prop.name, prop.multiProcessorCount, prop.totalGlobalMem, device_};
      int pools_supported = 0;
      CAUSTICA_CUDA_CHECK(
          cudaDeviceGetAttribute(&pools_supported, cudaDevAttrMemoryPoolsSupported, device_));
      if (!pools_supported) {
        throw DeviceError(absl::StrFormat("%s has no stream-ordered memory pools", prop.name));
      }
      // Non-blocking: the legacy default stream, which other libraries in the process may use,
      // never serialises with this backend's work.
      CAUSTICA_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
      cudaMemPoolProps props = {};
      props.allocType = cudaMemAllocationTypePinned;
      props.handleTypes = cudaMemHandleTypeNone;
      props.location.type = cudaMemLocationTypeDevice;
      props.location.id = device_;
      CAUSTICA_CUDA_CHECK(cudaMemPoolCreate(&pool_, &props));
      // Freed memory stays in the pool up to the budget instead of going back to the driver at
      // every synchronisation, so per-frame rebuilds reuse it without new mappings.
      uint64_t keep =
          memory_budget_bytes < prop.totalGlobalMem ? memory_budget_bytes : prop.totalGlobalMem;
      CAUSTICA_CUDA_CHECK(cudaMemPoolSetAttribute(pool_, cudaMemPoolAttrReleaseThreshold, &keep));
      CAUSTICA_CUDA_CHECK(cudaMallocHost(&staging_, kStagingBytes));
    } catch (...) {
      release();
      throw;
    }
  }
  ~CudaBackend() override { release(); }

  cudaStream_t stream() const { return stream_; }

  DeviceKind kind() const override { return DeviceKind::kCuda; }
  DeviceInfo info() const override { return info_; }

  void* allocate_host(size_t bytes) override {
    void* p = nullptr;
    CAUSTICA_CUDA_CHECK(cudaMallocHost(&p, bytes));
    return p;
  }
  void deallocate_host(void* p) noexcept override { CAUSTICA_CUDA_LOG(cudaFreeHost(p)); }

  // Returns once `src` may be reused: callers upload from temporaries.
  void copy_to_device(void* dst, const void* src, size_t bytes) override {
    CAUSTICA_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyHostToDevice, stream_));
    CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_));
  }
  void copy_to_host(void* dst, const void* src, size_t bytes) override {
    CAUSTICA_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, stream_));
    CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_));
  }
  // Overlapping ranges are allowed, as with the CPU backend's memmove; cudaMemcpy forbids them,
  // so those go through a temporary.
  void copy_on_device(void* dst, const void* src, size_t bytes) override {
    if (bytes == 0 || dst == src) return;
    const auto* d = static_cast<const std::byte*>(dst);
    const auto* s = static_cast<const std::byte*>(src);
    if (d < s + bytes && s < d + bytes) {
      Buffer<std::byte> tmp(*this, bytes);
      CAUSTICA_CUDA_CHECK(
          cudaMemcpyAsync(tmp.data(), src, bytes, cudaMemcpyDeviceToDevice, stream_));
      CAUSTICA_CUDA_CHECK(
          cudaMemcpyAsync(dst, tmp.data(), bytes, cudaMemcpyDeviceToDevice, stream_));
      return;
    }
    CAUSTICA_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToDevice, stream_));
  }
  void fill_bytes(void* dst, uint8_t value, size_t bytes) override {
    CAUSTICA_CUDA_CHECK(cudaMemsetAsync(dst, value, bytes, stream_));
  }
  void synchronize() override { CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_)); }
  void make_current() override { CAUSTICA_CUDA_CHECK(cudaSetDevice(device_)); }

  void copy_from(Backend& source, void* dst, const void* src, size_t bytes) override {
    if (source.kind() != DeviceKind::kCuda || bytes == 0) {
      Backend::copy_from(source, dst, src, bytes);
      return;
    }
    const int from = static_cast<CudaBackend&>(source).device_;
    if (from == device_) {
      CAUSTICA_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToDevice, stream_));
      return;
    }
    enable_peer_access(from);
    CAUSTICA_CUDA_CHECK(cudaMemcpyPeerAsync(dst, device_, src, from, bytes, stream_));
  }
  // Events on the stream time the device work alone, not the host's launch overhead around it.
  double time_ms(const std::function<void()>& fn) override {
    cudaEvent_t start, stop;
    CAUSTICA_CUDA_CHECK(cudaEventCreate(&start));
    CAUSTICA_CUDA_CHECK(cudaEventCreate(&stop));
    CAUSTICA_CUDA_CHECK(cudaEventRecord(start, stream_));
    fn();
    CAUSTICA_CUDA_CHECK(cudaEventRecord(stop, stream_));
    CAUSTICA_CUDA_CHECK(cudaEventSynchronize(stop));
    float ms = 0;
    CAUSTICA_CUDA_CHECK(cudaEventElapsedTime(&ms, start, stop));
    CAUSTICA_CUDA_CHECK(cudaEventDestroy(start));
    CAUSTICA_CUDA_CHECK(cudaEventDestroy(stop));
    return ms;
  }

  // Each primitive is one timed launch under the name the CPU backend gives it, so that the two
  // backends' tables compare; its events bracket all it queues (CUB's passes, copies back).
  void sort_pairs(uint32_t* keys, uint32_t* values, size_t n, int end_bit) override {
    timed_launch("sort_pairs", [&] { radix_sort(keys, values, n, end_bit); });
  }
  void sort_pairs(uint64_t* keys, uint32_t* values, size_t n, int end_bit) override {
    timed_launch("sort_pairs", [&] { radix_sort(keys, values, n, end_bit); });
  }
  uint32_t exclusive_scan(const uint32_t* in, uint32_t* out, size_t n) override {
    return timed_launch("exclusive_scan", [&] { return scan<uint32_t, uint32_t>(in, out, n); });
  }
  float exclusive_scan(const float* in, float* out, size_t n) override {
    return timed_launch("exclusive_scan", [&] { return scan<float, double>(in, out, n); });
  }
  uint64_t reduce_sum(const uint32_t* in, size_t n) override {
    return timed_launch("reduce_sum",
                        [&] { return reduce(in, n, ::cuda::std::plus<uint64_t>(), uint64_t{0}); });
  }
  double reduce_sum(const float* in, size_t n) override {
    return timed_launch("reduce_sum",
                        [&] { return reduce(in, n, ::cuda::std::plus<double>(), 0.0); });
  }
  float reduce_max(const float* in, size_t n) override {
    return timed_launch("reduce_max", [&] { return reduce(in, n, MaxOp(), -FLT_MAX); });
  }
  Aabb reduce_bounds(const Aabb* in, size_t n) override {
    return timed_launch("reduce_bounds", [&] { return reduce(in, n, MergeBoundsOp(), Aabb{}); });
  }
  void reduce_bounds_to(const Aabb* in, size_t n, Aabb* out) override {
    timed_launch("reduce_bounds", [&] { reduce_to(in, n, MergeBoundsOp(), Aabb{}, out); });
  }

  size_t select_flagged(const uint32_t* in, const uint8_t* flags, size_t n,
                        uint32_t* out) override {
    return timed_launch("select_flagged", [&] { return select(in, flags, n, out); });
  }

  size_t run_length_encode(const uint32_t* in, size_t n, uint32_t* unique_out,
                           uint32_t* counts_out) override {
    return timed_launch("run_length_encode",
                        [&] { return encode_runs(in, n, unique_out, counts_out); });
  }

  // A pair of events on the stream around the launch; the mark is the pair's place in pending_.
  uint64_t launch_began(const char* name) override {
    std::lock_guard<std::mutex> lock(events_mutex_);
    // Events are read only when the times are asked for; a run that never asks is held to a
    // bounded number of them by reading what is pending now and then.
    if (pending_.size() >= kMaxPendingLaunches) collect_pending();
    PendingLaunch launch{name, take_event(), nullptr};
    CAUSTICA_CUDA_CHECK(cudaEventRecord(launch.start, stream_));
    pending_.push_back(launch);
    return pending_.size() - 1;
  }
  void launch_ended(const char*, uint64_t mark, bool launched) override {
    std::lock_guard<std::mutex> lock(events_mutex_);
    if (mark >= pending_.size()) return;  // read since it began: the launch goes uncounted
    PendingLaunch& launch = pending_[mark];
    if (!launched) return;  // collect_pending gives back the start event
    launch.stop = take_event();
    CAUSTICA_CUDA_CHECK(cudaEventRecord(launch.stop, stream_));
  }

 protected:
  void collect_launch_times() override {
    std::lock_guard<std::mutex> lock(events_mutex_);
    collect_pending();
  }

 private:
  size_t select(const uint32_t* in, const uint8_t* flags, size_t n, uint32_t* out) {
    if (n == 0) return 0;
    Buffer<int64_t> selected(*this, 1);
    if (in != nullptr) {
      run_cub("cub::DeviceSelect::Flagged", [&](void* temp, size_t& temp_bytes) {
        return cub::DeviceSelect::Flagged(temp, temp_bytes, in, flags, out, selected.data(),
                                          int64_t(n), stream_);
      });
    } else {
      // Selected indices: the input is the sequence 0, 1, 2, ...
      run_cub("cub::DeviceSelect::Flagged", [&](void* temp, size_t& temp_bytes) {
        return cub::DeviceSelect::Flagged(temp, temp_bytes,
                                          thrust::make_counting_iterator<uint32_t>(0), flags, out,
                                          selected.data(), int64_t(n), stream_);
      });
    }
    return size_t(fetch(selected.data()));
  }

  size_t encode_runs(const uint32_t* in, size_t n, uint32_t* unique_out, uint32_t* counts_out) {
    if (n == 0) return 0;
    if (n > size_t(INT_MAX)) {
      throw DeviceError(
          absl::StrFormat("run_length_encode: %d keys; CUB takes at most %d", n, INT_MAX));
    }
    Buffer<int> runs(*this, 1);
    run_cub("cub::DeviceRunLengthEncode::Encode", [&](void* temp, size_t& temp_bytes) {
      return cub::DeviceRunLengthEncode::Encode(temp, temp_bytes, in, unique_out, counts_out,
                                                runs.data(), int(n), stream_);
    });
    return size_t(fetch(runs.data()));
  }

 protected:
  void* allocate_raw(size_t bytes) override {
    const DeviceScope scope(device_);
    void* p = nullptr;
    const cudaError_t status = cudaMallocFromPoolAsync(&p, bytes, pool_, stream_);
    if (status == cudaErrorMemoryAllocation) {
      cudaGetLastError();  // not sticky: clear it so later calls do not report it again
      throw std::bad_alloc();
    }
    CAUSTICA_CUDA_CHECK(status);
    return p;
  }
  // Ordered on the stream after all work queued so far, so buffers may be dropped while kernels
  // that read them are still running.
  void deallocate_raw(void* p, size_t) override {
    const DeviceScope scope(device_);
    CAUSTICA_CUDA_LOG(cudaFreeAsync(p, stream_));
  }

 private:
  static constexpr size_t kStagingBytes = 256;
  static constexpr size_t kMaxPendingLaunches = size_t(1) << 14;

  // A timed launch whose events have not been read yet; stop is null until it has ended.
  struct PendingLaunch {
    const char* name;
    cudaEvent_t start, stop;
  };

  // An event from the pool, made when the pool is empty. Callers hold events_mutex_.
  cudaEvent_t take_event() {
    if (free_events_.empty()) {
      cudaEvent_t event;
      CAUSTICA_CUDA_CHECK(cudaEventCreate(&event));
      events_.push_back(event);
      return event;
    }
    const cudaEvent_t event = free_events_.back();
    free_events_.pop_back();
    return event;
  }

  // Waits for the stream, adds each ended launch's time to the table and gives its events back
  // to the pool. Callers hold events_mutex_.
  void collect_pending() {
    if (pending_.empty()) return;
    CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_));
    for (const PendingLaunch& launch : pending_) {
      if (launch.stop != nullptr) {
        float ms = 0;
        CAUSTICA_CUDA_CHECK(cudaEventElapsedTime(&ms, launch.start, launch.stop));
        add_launch_time(launch.name, 1, ms);
        free_events_.push_back(launch.stop);
      }
      free_events_.push_back(launch.start);
    }
    pending_.clear();
  }

  // Calls a CUB device-wide algorithm twice, as CUB prescribes: once for the size of its
  // temporary storage, then with storage from this backend's pool.
  template <typename Call>
  void run_cub(const char* name, Call call) {
    size_t temp_bytes = 0;
    cudaError_t status = call(nullptr, temp_bytes);
    if (status != cudaSuccess) throw_cuda_error(status, name, __FILE__, __LINE__);
    // At least one byte: a null pointer would ask CUB for the size again instead of running.
    Buffer<std::byte> temp(*this, temp_bytes > 0 ? temp_bytes : 1);
    status = call(temp.data(), temp_bytes);
    if (status != cudaSuccess) throw_cuda_error(status, name, __FILE__, __LINE__);
  }

  // A small result the device wrote, brought to the host through pinned memory; waits for the
  // stream. The staging block is shared, hence the lock (engines may share a backend).
  template <typename T>
  T fetch(const T* device_value) {
    static_assert(sizeof(T) <= kStagingBytes);
    std::lock_guard<std::mutex> lock(staging_mutex_);
    CAUSTICA_CUDA_CHECK(
        cudaMemcpyAsync(staging_, device_value, sizeof(T), cudaMemcpyDeviceToHost, stream_));
    CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_));
    T value;
    std::memcpy(&value, staging_, sizeof(T));
    return value;
  }

  // Stable and in place, like the CPU sort; CUB ping-pongs between the arrays and a second pair,
  // and the result is copied back when it ends in the second pair.
  template <typename Key>
  void radix_sort(Key* keys, uint32_t* values, size_t n, int end_bit) {
    if (n < 2 || end_bit <= 0) return;
    const int bits = end_bit < int(8 * sizeof(Key)) ? end_bit : int(8 * sizeof(Key));
    Buffer<Key> keys_alt(*this, n);
    Buffer<uint32_t> values_alt(*this, n);
    cub::DoubleBuffer<Key> key_buffers(keys, keys_alt.data());
    cub::DoubleBuffer<uint32_t> value_buffers(values, values_alt.data());
    run_cub("cub::DeviceRadixSort::SortPairs", [&](void* temp, size_t& temp_bytes) {
      return cub::DeviceRadixSort::SortPairs(temp, temp_bytes, key_buffers, value_buffers, n, 0,
                                             bits, stream_);
    });
    if (key_buffers.Current() != keys) copy_on_device(keys, key_buffers.Current(), n * sizeof(Key));
    if (value_buffers.Current() != values) {
      copy_on_device(values, value_buffers.Current(), n * sizeof(uint32_t));
    }
  }

  // Exclusive prefix sums in Acc (double for floats, as on the CPU), in place when in == out.
  template <typename T, typename Acc>
  T scan(const T* in, T* out, size_t n) {
    if (n == 0) return T(0);
    Buffer<Acc> total(*this, 1);
    auto input = thrust::make_transform_iterator(thrust::make_counting_iterator<size_t>(0),
                                                 ScanInput<T, Acc>{in, n});
    auto output = thrust::make_tabulate_output_iterator(ScanOutput<T, Acc>{out, n, total.data()});
    run_cub("cub::DeviceScan::ExclusiveScan", [&](void* temp, size_t& temp_bytes) {
      return cub::DeviceScan::ExclusiveScan(temp, temp_bytes, input, output,
                                            ::cuda::std::plus<Acc>(), Acc(0), n + 1, stream_);
    });
    return T(fetch(total.data()));
  }

  // `init` is the identity of `op` and the result for n == 0.
  template <typename In, typename Op, typename Acc>
  Acc reduce(const In* in, size_t n, Op op, Acc init) {
    if (n == 0) return init;
    Buffer<Acc> result(*this, 1);
    reduce_to(in, n, op, init, result.data());
    return fetch(result.data());
  }
  // Leaves the result at `out` in device memory, ordered on the stream.
  template <typename In, typename Op, typename Acc>
  void reduce_to(const In* in, size_t n, Op op, Acc init, Acc* out) {
    if (n == 0) {
      CAUSTICA_CUDA_CHECK(
          cudaMemcpyAsync(out, &init, sizeof(Acc), cudaMemcpyHostToDevice, stream_));
      CAUSTICA_CUDA_CHECK(cudaStreamSynchronize(stream_));  // `init` is on this frame
      return;
    }
    run_cub("cub::DeviceReduce::Reduce", [&](void* temp, size_t& temp_bytes) {
      return cub::DeviceReduce::Reduce(temp, temp_bytes, in, out, n, op, init, stream_);
    });
  }

  // Idempotent, so the constructor can undo a partial set-up with it.
  void release() noexcept {
    const DeviceScope scope(device_);
    if (stream_ != nullptr) CAUSTICA_CUDA_LOG(cudaStreamSynchronize(stream_));
    for (cudaEvent_t event : events_) CAUSTICA_CUDA_LOG(cudaEventDestroy(event));
    events_.clear();
    free_events_.clear();
    pending_.clear();
    if (staging_ != nullptr) CAUSTICA_CUDA_LOG(cudaFreeHost(staging_));
    if (pool_ != nullptr) CAUSTICA_CUDA_LOG(cudaMemPoolDestroy(pool_));
    if (stream_ != nullptr) CAUSTICA_CUDA_LOG(cudaStreamDestroy(stream_));
    staging_ = nullptr;
    pool_ = nullptr;
    stream_ = nullptr;
  }

  // Lets this device read `peer`'s memory directly where the two are linked (NVLink or PCIe
  // peer to peer), once; without it cudaMemcpyPeerAsync stages through the host.
  void enable_peer_access(int peer) {
    std::lock_guard<std::mutex> lock(peers_mutex_);
    if (!peers_tried_.insert(peer).second) return;
    int can = 0;
    CAUSTICA_CUDA_CHECK(cudaDeviceCanAccessPeer(&can, device_, peer));
    if (!can) return;
    const cudaError_t status = cudaDeviceEnablePeerAccess(peer, 0);
    if (status == cudaErrorPeerAccessAlreadyEnabled) {
      cudaGetLastError();
    } else {
      CAUSTICA_CUDA_CHECK(status);
    }
  }

  int device_ = 0;
  DeviceInfo info_;
  std::mutex peers_mutex_;
  std::set<int> peers_tried_;
  cudaStream_t stream_ = nullptr;
  cudaMemPool_t pool_ = nullptr;
  void* staging_ = nullptr;  // pinned
  std::mutex staging_mutex_;
  // Launch timing's events: every one made (destroyed with the backend), those free for reuse,
  // and the launches whose times are still to be read.
  std::mutex events_mutex_;
  std::vector<cudaEvent_t> events_, free_events_;
  std::vector<PendingLaunch> pending_;
};

}  // namespace

cudaStream_t cuda_stream(Backend& backend) {
  if (backend.kind() != DeviceKind::kCuda) {
    throw DeviceError("cuda_stream: not a CUDA backend");
  }
  return static_cast<CudaBackend&>(backend).stream();
}

bool cuda_device_available() {
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess) {
    cudaGetLastError();  // no driver or no device: clear the error, it is an answer here
    return false;
  }
  return count > 0;
}

int cuda_device_count() {
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return count;
}

std::unique_ptr<Backend> make_cuda_backend(size_t memory_budget_bytes, int ordinal) {
  return std::make_unique<CudaBackend>(memory_budget_bytes, ordinal);
}

}  // namespace caustica
