// Gives the heap's free pages back to the operating system every few seconds when enough of them
// are free. glibc keeps what a burst of traffic freed (an oversized message refused, a storm of
// connections) in its arenas, so without this a server's resident memory only ever grows, and a
// leak cannot be told from the allocator's keepings (docs/reliability.md, "Hostile clients").
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <thread>

namespace caustica::server {

class HeapTrimmer {
 public:
  // Every `period`, trims when more than `min_free_bytes` of the heap is free.
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
