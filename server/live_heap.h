// The bytes of the process's live heap allocations, as its allocator counts them: what a leak
// grows, without the freed memory an allocator keeps resident. Under AddressSanitizer that is
// its quarantine, which holds freed blocks and so grows resident memory for hundreds of megabytes
// without a leak; GetStats reports the figure so that a soak can judge the heap instead.
#pragma once

#include <cstddef>
#include <cstdint>

#if defined(__SANITIZE_ADDRESS__)
#define CAUSTICA_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CAUSTICA_ADDRESS_SANITIZER 1
#endif
#endif

#if defined(CAUSTICA_ADDRESS_SANITIZER)
// GCC ships the runtime's function without the header that declares it.
extern "C" size_t __sanitizer_get_current_allocated_bytes();
#elif defined(__GLIBC__)
#include <malloc.h>
#endif

namespace caustica {

// Whether this build runs under AddressSanitizer (a server and a soak from one build tree agree).
inline constexpr bool kAddressSanitizer =
#if defined(CAUSTICA_ADDRESS_SANITIZER)
    true;
#else
    false;
#endif

// 0 where the allocator does not tell (neither AddressSanitizer's nor glibc 2.33's or later).
inline uint64_t live_heap_bytes() {
#if defined(CAUSTICA_ADDRESS_SANITIZER)
  // Blocks in the quarantine count as freed.
  return __sanitizer_get_current_allocated_bytes();
#elif defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  // Allocated bytes in the arenas, and the blocks large enough to be mapped on their own.
  const struct mallinfo2 info = mallinfo2();
  return uint64_t{info.uordblks} + uint64_t{info.hblkhd};
#else
  return 0;
#endif
}

}  // namespace caustica
