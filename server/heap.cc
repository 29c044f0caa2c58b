#include "server/heap.h"

#if defined(CAUSTICA_ADDRESS_SANITIZER)
// GCC ships the runtime's function without the header that declares it.
extern "C" size_t __sanitizer_get_current_allocated_bytes();
#elif defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
#include <malloc.h>
#define CAUSTICA_GLIBC_MALLINFO2 1
#endif

namespace caustica::server {

uint64_t live_heap_bytes() {
#if defined(CAUSTICA_ADDRESS_SANITIZER)
  return __sanitizer_get_current_allocated_bytes();
#elif defined(CAUSTICA_GLIBC_MALLINFO2)
  // Allocated bytes in the arenas, and the blocks large enough to be mapped on their own.
  const struct mallinfo2 info = mallinfo2();
  return uint64_t{info.uordblks} + uint64_t{info.hblkhd};
#else
  return 0;
#endif
}

HeapTrimmer::HeapTrimmer(std::chrono::milliseconds period, size_t min_free_bytes)
    : thread_([this, period, min_free_bytes] {
        std::unique_lock lock(mutex_);
        while (!stop_requested_.wait_for(lock, period, [this] { return stopping_; })) {
          lock.unlock();
          trim_if_worth_it(min_free_bytes);
          lock.lock();
        }
      }) {}

HeapTrimmer::~HeapTrimmer() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  stop_requested_.notify_all();
  thread_.join();
}

bool HeapTrimmer::trim_if_worth_it(size_t min_free_bytes) {
#if defined(CAUSTICA_GLIBC_MALLINFO2)
  // fordblks: free bytes held in the arenas' chunks, the part malloc_trim can give back.
  if (mallinfo2().fordblks < min_free_bytes) return false;
  malloc_trim(0);
  return true;
#else
  (void)min_free_bytes;
  return false;
#endif
}

}  // namespace caustica::server
