// The first step of every LBVH build here (triangles and photons alike): Morton codes of the
// primitives' box centres on a 1024^3 grid over their bounds, below a bit for huge boxes
// (extended_morton_code, base/morton.h), radix-sorted with the indices.
#pragma once

#include "renderer/parallel/buffer.h"

namespace caustica {

struct MortonOrder {
  Buffer<uint32_t> codes;  // ascending
  Buffer<uint32_t> order;  // order[i]: the primitive with the i-th code
};

// `boxes` holds one box per primitive (degenerate for points); `bounds`, in the backend's memory,
// is their reduction (Backend::reduce_bounds_to), read by the kernel so the host need not wait.
MortonOrder sort_by_morton(Backend& backend, const Aabb* boxes, uint32_t n, const Aabb* bounds);

}  // namespace caustica
