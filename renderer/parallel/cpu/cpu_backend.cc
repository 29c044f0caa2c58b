// CPU backend: the primitive layer on oneTBB. The sorts and scans are chunked the way GPU
// primitives are (per-chunk histogram or sum, a scan over chunks, per-chunk scatter), which keeps
// them parallel, stable and deterministic whatever the thread count.
#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include "renderer/parallel/backend.h"
#include "renderer/parallel/buffer.h"

namespace caustica {
namespace {

constexpr size_t kSerialBelow = 1 << 14;

// Splits [0, n) into contiguous chunks of at least kSerialBelow elements, at most four per core;
// a serial Chunking is one chunk.
struct Chunking {
  size_t n, count, size;
  explicit Chunking(size_t n_, bool parallel = true) : n(n_) {
    size_t max_chunks = parallel ? 4 * std::max<size_t>(1, tbb::info::default_concurrency()) : 1;
    count = std::clamp<size_t>(n / kSerialBelow, 1, max_chunks);
    size = (n + count - 1) / count;
  }
  size_t begin(size_t c) const { return std::min(n, c * size); }
  size_t end(size_t c) const { return std::min(n, (c + 1) * size); }
};

template <typename Fn>
void for_each_chunk(const Chunking& chunks, Fn fn) {
  if (chunks.count == 1) {
    fn(size_t{0});
    return;
  }
  tbb::parallel_for(size_t{0}, chunks.count, [&](size_t c) { fn(c); });
}

// One stable counting-sort pass on the digit (key >> shift) & (buckets - 1), from src to dst.
// Returns where each bucket ends in dst: the last chunk's write cursors after the scatter.
template <typename Key>
const uint32_t* scatter_by_digit(const Key* key_src, const uint32_t* val_src, Key* key_dst,
                                 uint32_t* val_dst, size_t n, int shift, size_t buckets,
                                 std::vector<uint32_t>& counts, bool parallel) {
  const Key mask = Key(buckets - 1);
  Chunking chunks(n, parallel);
  counts.assign(chunks.count * buckets, 0);
  for_each_chunk(chunks, [&](size_t c) {
    uint32_t* count = &counts[c * buckets];
    for (size_t i = chunks.begin(c); i < chunks.end(c); ++i) ++count[(key_src[i] >> shift) & mask];
  });
  // Exclusive offsets, digit-major then chunk order, which makes the scatter stable.
  uint32_t running = 0;
  for (size_t d = 0; d < buckets; ++d)
    for (size_t c = 0; c < chunks.count; ++c)
      running += std::exchange(counts[c * buckets + d], running);
  for_each_chunk(chunks, [&](size_t c) {
    uint32_t* offset = &counts[c * buckets];
    for (size_t i = chunks.begin(c); i < chunks.end(c); ++i) {
      uint32_t pos = offset[(key_src[i] >> shift) & mask]++;
      key_dst[pos] = key_src[i];
      val_dst[pos] = val_src[i];
    }
  });
  return &counts[(chunks.count - 1) * buckets];
}

// Stable LSD sort of the low `bits` bits, an odd number of passes from (src) to (dst), so the
// result lands in dst; used on cache-sized buckets.
template <typename Key>
void lsd_sort_into(Key* key_src, uint32_t* val_src, Key* key_dst, uint32_t* val_dst, size_t n,
                   int bits, std::vector<uint32_t>& counts) {
  if (bits <= 0 || n < 2) {
    std::memcpy(key_dst, key_src, n * sizeof(Key));
    std::memcpy(val_dst, val_src, n * sizeof(uint32_t));
    return;
  }
  int passes = (bits + 7) / 8;
  if (passes % 2 == 0) ++passes;
  const int digit_bits = (bits + passes - 1) / passes;
  for (int p = 0; p < passes; ++p) {
    scatter_by_digit(key_src, val_src, key_dst, val_dst, n, p * digit_bits, size_t{1} << digit_bits,
                     counts, /*parallel=*/false);
    std::swap(key_src, key_dst);
    std::swap(val_src, val_dst);
  }
}

// Stable radix sort of the key bits [0, end_bit). One parallel pass scatters by the top 10 bits
// into the scratch arrays; every bucket, now small enough for the cache, is then LSD-sorted back
// into place independently and in parallel. Only the first pass moves data across all of memory.
template <typename Key>
void radix_sort_pairs(Key* keys, uint32_t* values, size_t n, int end_bit, Key* keys_tmp,
                      uint32_t* values_tmp) {
  if (n < 2 || end_bit <= 0) return;
  const int top_bits = std::min(end_bit, 10);
  const int low_bits = end_bit - top_bits;
  const size_t buckets = size_t{1} << top_bits;
  std::vector<uint32_t> counts;
  const uint32_t* bucket_end =
      scatter_by_digit(keys, values, keys_tmp, values_tmp, n, low_bits, buckets, counts, true);
  tbb::parallel_for(size_t{0}, buckets, [&](size_t d) {
    thread_local std::vector<uint32_t> local_counts;
    size_t begin = d == 0 ? 0 : bucket_end[d - 1], size = bucket_end[d] - begin;
    lsd_sort_into(keys_tmp + begin, values_tmp + begin, keys + begin, values + begin, size,
                  low_bits, local_counts);
  });
}

// Sums run in Acc (double for floats) so a scan of a million floats keeps float precision.
template <typename T, typename Acc>
T chunked_exclusive_scan(const T* in, T* out, size_t n) {
  if (n == 0) return T(0);
  Chunking chunks(n);
  std::vector<Acc> sums(chunks.count, Acc(0));
  for_each_chunk(chunks, [&](size_t c) {
    Acc s = Acc(0);
    for (size_t i = chunks.begin(c); i < chunks.end(c); ++i) s += in[i];
    sums[c] = s;
  });
  Acc running = Acc(0);
  for (Acc& s : sums) running += std::exchange(s, running);
  for_each_chunk(chunks, [&](size_t c) {
    Acc s = sums[c];
    for (size_t i = chunks.begin(c); i < chunks.end(c); ++i) {
      T v = in[i];  // read before write: in and out may alias
      out[i] = T(s);
      s += v;
    }
  });
  return T(running);
}

template <typename Acc, typename T, typename Op>
Acc parallel_reduce(const T* in, size_t n, Acc identity, Op op) {
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n, 4096), identity,
      [&](const tbb::blocked_range<size_t>& r, Acc acc) {
        for (size_t i = r.begin(); i != r.end(); ++i) acc = op(acc, Acc(in[i]));
        return acc;
      },
      op);
}

size_t physical_memory_bytes() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  size_t kib = 0;
  while (meminfo >> key >> kib) {
    if (key == "MemTotal:") return kib * 1024;
    meminfo.ignore(1 << 10, '\n');
  }
  return 0;
}

class CpuBackend final : public Backend {
 public:
  using Backend::Backend;

  DeviceKind kind() const override { return DeviceKind::kCpu; }
  DeviceInfo info() const override {
    return {"CPU (oneTBB)", tbb::info::default_concurrency(), physical_memory_bytes()};
  }

  void* allocate_host(size_t bytes) override { return ::operator new(bytes, std::align_val_t(64)); }
  void deallocate_host(void* p) noexcept override { ::operator delete(p, std::align_val_t(64)); }

  // An empty buffer's pointer is null, which the C library's copies must not be given even for
  // no bytes: nothing is done then.
  void copy_to_device(void* dst, const void* src, size_t bytes) override {
    if (bytes > 0) std::memcpy(dst, src, bytes);
  }
  void copy_to_host(void* dst, const void* src, size_t bytes) override {
    if (bytes > 0) std::memcpy(dst, src, bytes);
  }
  void copy_on_device(void* dst, const void* src, size_t bytes) override {
    if (bytes > 0) std::memmove(dst, src, bytes);
  }
  void fill_bytes(void* dst, uint8_t value, size_t bytes) override {
    if (bytes > 0) std::memset(dst, value, bytes);
  }
  void synchronize() override {}

  // Each primitive is one timed launch under its own name (Backend::timed_launch); the ones built
  // on others call the untimed forms, so that a launch is counted once.
  void sort_pairs(uint32_t* keys, uint32_t* values, size_t n, int end_bit) override {
    timed_launch("sort_pairs", [&] { sort_with_scratch(keys, values, n, end_bit); });
  }
  void sort_pairs(uint64_t* keys, uint32_t* values, size_t n, int end_bit) override {
    timed_launch("sort_pairs", [&] { sort_with_scratch(keys, values, n, end_bit); });
  }
  uint32_t exclusive_scan(const uint32_t* in, uint32_t* out, size_t n) override {
    return timed_launch("exclusive_scan",
                        [&] { return chunked_exclusive_scan<uint32_t, uint32_t>(in, out, n); });
  }
  float exclusive_scan(const float* in, float* out, size_t n) override {
    return timed_launch("exclusive_scan",
                        [&] { return chunked_exclusive_scan<float, double>(in, out, n); });
  }
  uint64_t reduce_sum(const uint32_t* in, size_t n) override {
    return timed_launch("reduce_sum", [&] {
      return parallel_reduce<uint64_t>(in, n, uint64_t{0}, std::plus<uint64_t>());
    });
  }
  double reduce_sum(const float* in, size_t n) override {
    return timed_launch("reduce_sum",
                        [&] { return parallel_reduce<double>(in, n, 0.0, std::plus<double>()); });
  }
  float reduce_max(const float* in, size_t n) override {
    return timed_launch("reduce_max", [&] {
      return parallel_reduce<float>(in, n, -FLT_MAX,
                                    [](float a, float b) { return std::max(a, b); });
    });
  }
  Aabb reduce_bounds(const Aabb* in, size_t n) override {
    return timed_launch("reduce_bounds", [&] { return bounds_of(in, n); });
  }
  void reduce_bounds_to(const Aabb* in, size_t n, Aabb* out) override {
    timed_launch("reduce_bounds", [&] { *out = bounds_of(in, n); });
  }

  template <typename Key>
  void sort_with_scratch(Key* keys, uint32_t* values, size_t n, int end_bit) {
    if (n < 2) return;
    Buffer<Key> keys_tmp(*this, n);
    Buffer<uint32_t> values_tmp(*this, n);
    radix_sort_pairs(keys, values, n, end_bit, keys_tmp.data(), values_tmp.data());
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

 protected:
  // Freed blocks are kept for reuse, like a CUDA stream-ordered pool: rebuilding a structure every
  // frame then touches warm pages instead of faulting fresh ones from the kernel.
  void* allocate_raw(size_t bytes) override {
    const size_t rounded = (bytes + 63) & ~size_t{63};
    std::lock_guard lock(pool_mutex_);
    auto it = pool_.lower_bound(rounded);
    if (it != pool_.end() && it->first <= 2 * rounded) {
      void* p = it->second;
      pooled_bytes_ -= it->first;
      block_sizes_[p] = it->first;
      pool_.erase(it);
      return p;
    }
    // 64-byte alignment: one cache line, and what SIMD loads of node arrays want.
    void* p = std::aligned_alloc(64, rounded);
    if (p == nullptr) throw std::bad_alloc();
    block_sizes_[p] = rounded;
    return p;
  }
  void deallocate_raw(void* p, size_t) override {
    std::lock_guard lock(pool_mutex_);
    auto it = block_sizes_.find(p);
    const size_t size = it->second;
    block_sizes_.erase(it);
    if (pooled_bytes_ + size > kMaxPooledBytes) {
      std::free(p);
      return;
    }
    pool_.emplace(size, p);
    pooled_bytes_ += size;
  }

 public:
  ~CpuBackend() override {
    for (auto& [size, p] : pool_) std::free(p);
  }

 private:
  static Aabb bounds_of(const Aabb* in, size_t n) {
    return parallel_reduce<Aabb>(in, n, Aabb{}, [](Aabb a, const Aabb& b) { return merge(a, b); });
  }

  static size_t select(const uint32_t* in, const uint8_t* flags, size_t n, uint32_t* out) {
    if (n == 0) return 0;
    Chunking chunks(n);
    std::vector<size_t> offsets(chunks.count);
    for_each_chunk(chunks, [&](size_t c) {
      size_t k = 0;
      for (size_t i = chunks.begin(c); i < chunks.end(c); ++i) k += flags[i] != 0;
      offsets[c] = k;
    });
    size_t total = 0;
    for (size_t& o : offsets) total += std::exchange(o, total);
    for_each_chunk(chunks, [&](size_t c) {
      size_t k = offsets[c];
      for (size_t i = chunks.begin(c); i < chunks.end(c); ++i)
        if (flags[i]) out[k++] = in ? in[i] : uint32_t(i);
    });
    return total;
  }

  static size_t encode_runs(const uint32_t* in, size_t n, uint32_t* unique_out,
                            uint32_t* counts_out) {
    if (n == 0) return 0;
    std::vector<uint8_t> heads(n);
    tbb::parallel_for(size_t{0}, n, [&](size_t i) { heads[i] = i == 0 || in[i] != in[i - 1]; });
    std::vector<uint32_t> starts(n);
    size_t runs = select(nullptr, heads.data(), n, starts.data());
    tbb::parallel_for(size_t{0}, runs, [&](size_t r) {
      unique_out[r] = in[starts[r]];
      counts_out[r] = uint32_t((r + 1 < runs ? starts[r + 1] : n) - starts[r]);
    });
    return runs;
  }

  static constexpr size_t kMaxPooledBytes = size_t(2) << 30;
  std::mutex pool_mutex_;
  std::multimap<size_t, void*> pool_;              // free blocks by size
  std::unordered_map<void*, size_t> block_sizes_;  // blocks in use and their rounded size
  size_t pooled_bytes_ = 0;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_backend(size_t memory_budget_bytes) {
  return std::make_unique<CpuBackend>(memory_budget_bytes);
}

}  // namespace caustica
