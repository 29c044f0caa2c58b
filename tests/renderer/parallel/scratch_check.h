// A parallel_for_with_scratch body for tests on either backend: element i fills its scratch with
// values of its own, reads them all back and writes their sum, or ~0u if any value was not its own
// (scratch shared with another element, or too small).
#pragma once

#include <cstddef>
#include <cstdint>

#include "renderer/parallel/scratch.h"

namespace caustica {

struct ScratchCheck {
  uint32_t count;
  uint32_t* out;

  CAUSTICA_HD static uint32_t value(size_t i, uint32_t j) { return uint32_t(i) * 31u + j; }
  CAUSTICA_HD static uint32_t expected_sum(size_t i, uint32_t count) {
    uint32_t sum = 0;
    for (uint32_t j = 0; j < count; ++j) sum += value(i, j);
    return sum;
  }

  template <typename Scratch>
  CAUSTICA_HD void operator()(size_t i, Scratch scratch) const {
    for (uint32_t j = 0; j < count; ++j) scratch[j] = value(i, j);
    uint32_t sum = 0;
    bool own = true;
    for (uint32_t j = 0; j < count; ++j) {
      own = own && scratch[j] == value(i, j);
      sum += scratch[j];
    }
    out[i] = own ? sum : ~0u;
  }
};

}  // namespace caustica
