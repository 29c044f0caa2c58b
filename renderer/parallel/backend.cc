#include "renderer/parallel/backend.h"

#include <algorithm>
#include <chrono>

#include "absl/strings/str_format.h"

namespace caustica {

BudgetExceeded::BudgetExceeded(size_t requested, size_t in_use, size_t budget)
    : message_(
          absl::StrFormat("memory budget exceeded: %d bytes requested with %d of %d bytes in use",
                          requested, in_use, budget)) {}

void* Backend::allocate(size_t bytes) {
  if (bytes == 0) return nullptr;
  std::lock_guard<std::mutex> lock(memory_mutex_);
  if (bytes > budget_ || in_use_ > budget_ - bytes) throw BudgetExceeded(bytes, in_use_, budget_);
  void* p = allocate_raw(bytes);
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

double Backend::time_ms(const std::function<void()>& fn) {
  synchronize();
  const auto start = std::chrono::steady_clock::now();
  fn();
  synchronize();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace caustica
