#include "server/heap_trimmer.h"

#include <malloc.h>

namespace caustica::server {

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
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
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
