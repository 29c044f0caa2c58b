#include "proto/wire/frame_heap.h"

#include <cstddef>  // defines __GLIBC__ with glibc
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace caustica::wire {

void keep_frame_buffers() {
#if defined(__GLIBC__)
  // glibc maps a block above its threshold on its own and unmaps it when freed, and it gives the
  // heap's free top back past the trim threshold. Both thresholds fixed high keep a frame's few
  // blocks of megabytes for reuse (setting them also stops glibc moving them).
  constexpr int kMapAbove = 32 << 20;  // the largest glibc takes
  constexpr int kTrimAbove = 256 << 20;
  mallopt(M_MMAP_THRESHOLD, kMapAbove);
  mallopt(M_TRIM_THRESHOLD, kTrimAbove);
#endif
}

}  // namespace caustica::wire
