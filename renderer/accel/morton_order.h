// The first step of every LBVH build here (triangles and photons alike): Morton codes of the
// primitives' box centres on a 1024^3 grid over their bounds, below a bit for huge boxes
// (extended_morton_code, base/morton.h), radix-sorted with the indices.
#pragma once

#include "renderer/parallel/buffer.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

struct MortonOrder {
  Buffer<uint32_t> codes;  // ascending
  Buffer<uint32_t> order;  // order[i]: the primitive with the i-th code
};

// Codes `code_of(i)` (a CAUSTICA_HD functor giving a code below 2^end_bit) for i in [0, n),
// radix-sorted with the indices: the Morton order of anything with positions.
template <typename CodeOf>
MortonOrder sort_by_code(Backend& backend, uint32_t n, int end_bit, CodeOf code_of) {
  MortonOrder out{Buffer<uint32_t>(backend, n), Buffer<uint32_t>(backend, n)};
  uint32_t* code = out.codes.data();
  uint32_t* id = out.order.data();
  parallel_for(backend, n, [=] CAUSTICA_HD(size_t i) {
    code[i] = code_of(uint32_t(i));
    id[i] = uint32_t(i);
  });
  backend.sort_pairs(code, id, n, end_bit);
  return out;
}

// `boxes` holds one box per primitive (degenerate for points); `bounds`, in the backend's memory,
// is their reduction (Backend::reduce_bounds_to), read by the kernel so the host need not wait.
MortonOrder sort_by_morton(Backend& backend, const Aabb* boxes, uint32_t n, const Aabb* bounds);

}  // namespace caustica
