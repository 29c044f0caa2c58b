// The server's heap as its allocator sees it. Resident memory also holds what the allocator keeps
// of freed memory: glibc's arenas keep what a burst of traffic freed (an oversized message
// refused, a storm of connections), and AddressSanitizer's quarantine holds freed blocks by the
// hundreds of megabytes. So GetStats reports the live heap, which a leak grows and nothing else
// does, and a trimmer gives the freed pages back so that resident memory follows what is in use
// (docs/reliability.md, "Hostile clients" and "Soak").
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <thread>

#if defined(__SANITIZE_ADDRESS__)
#define CAUSTICA_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CAUSTICA_ADDRESS_SANITIZER 1
#endif
#endif

namespace caustica::server {

// Whether this build runs under AddressSanitizer (GCC's and clang's ways of saying so), whose
// quarantine makes resident memory no measure of what is in use.
#if defined(CAUSTICA_ADDRESS_SANITIZER)
inline constexpr bool kUnderAddressSanitizer = true;
#else
inline constexpr bool kUnderAddressSanitizer = false;
#endif

// The bytes of live allocations; 0 where the allocator does not tell (neither AddressSanitizer's
// nor glibc 2.33's or later). Blocks in AddressSanitizer's quarantine count as freed.
uint64_t live_heap_bytes();

// The server trims once this much of its heap is free: less would trim after every frame, whose
// buffers are freed and taken again at once.
inline constexpr size_t kServerTrimFreeBytes = size_t{16} << 20;

// Gives the heap's free pages back to the operating system every `period` when more than
// `min_free_bytes` are free.
class HeapTrimmer {
 public:
  HeapTrimmer(std::chrono::milliseconds period, size_t min_free_bytes);
  ~HeapTrimmer();
  HeapTrimmer(const HeapTrimmer&) = delete;
  HeapTrimmer& operator=(const HeapTrimmer&) = delete;

  // Trims now when enough is free; whether it trimmed.
  static bool trim_if_worth_it(size_t min_free_bytes);

 private:
  std::mutex mutex_;
  std::condition_variable stop_requested_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace caustica::server
