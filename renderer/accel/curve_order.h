// The first step of every LBVH build here (triangles and photons alike), and of the gather's
// request order: codes along a space-filling curve on a 1024^3 grid (base/morton.h), for boxes
// below a bit for huge ones (extended codes), radix-sorted with the indices.
#pragma once

#include "renderer/base/morton.h"
#include "renderer/parallel/buffer.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

struct CurveOrder {
  Buffer<uint32_t> codes;  // ascending
  Buffer<uint32_t> order;  // order[i]: the primitive with the i-th code
};

// Codes `code_of(id)` (a CAUSTICA_HD functor giving a code below 2^end_bit) of the ids
// `id_of(0)`, ..., `id_of(n - 1)`, a permutation of [0, n), radix-sorted with them. The sort is
// stable: equal codes keep the order id_of gives them.
template <typename CodeOf, typename IdOf>
CurveOrder sort_by_code(Backend& backend, uint32_t n, int end_bit, CodeOf code_of, IdOf id_of) {
  CurveOrder out{Buffer<uint32_t>(backend, n), Buffer<uint32_t>(backend, n)};
  uint32_t* code = out.codes.data();
  uint32_t* id = out.order.data();
  parallel_for(backend, "curve_codes", n, [=] CAUSTICA_HD(size_t i) {
    const uint32_t which = id_of(uint32_t(i));
    code[i] = code_of(which);
    id[i] = which;
  });
  backend.sort_pairs(code, id, n, end_bit);
  return out;
}

// The same for the ids 0, ..., n - 1 in order.
template <typename CodeOf>
CurveOrder sort_by_code(Backend& backend, uint32_t n, int end_bit, CodeOf code_of) {
  return sort_by_code(backend, n, end_bit, code_of, [] CAUSTICA_HD(uint32_t i) { return i; });
}

// Which curve a radix tree's leaves follow. Both give a tree of the same octree cells, split in
// halves; they differ in the order of the halves, and so in which primitives share a leaf or a
// small subtree:
// - triangles follow the Hilbert curve on a GPU, which never jumps between neighbouring cells, so
//   a leaf's triangles lie closer together and primary and incoherent rays run faster;
// - photons follow it on a GPU too: a leaf is a run of consecutive photons, and runs that never
//   jump make tighter leaves, so a search tests fewer photons.
// The figures are in docs/performance.md, "Tree quality and photon order".
enum class Curve { kMorton, kHilbert };

// The curve a backend's structures follow, triangles and photons alike: Hilbert on a GPU. Morton
// on the CPU, where a Hilbert code is a chain of dependent bit operations that the compiler does
// not vectorise: it slowed the LBVH build far more than it sped the rays there.
Curve backend_curve(const Backend& backend);

// The bits of a box's code along `curve` within `bounds`: the codes sort_by_curve sorts by.
inline constexpr int kCurveCodeBits = 31;

CAUSTICA_HDI uint32_t curve_code(Curve curve, const Aabb& box, const Aabb& bounds) {
  return curve == Curve::kHilbert ? extended_hilbert_code(box, bounds)
                                  : extended_morton_code(box, bounds);
}

// `boxes` holds one box per primitive (degenerate for points); `bounds`, in the backend's memory,
// is their reduction (Backend::reduce_bounds_to), read by the kernel so the host need not wait.
CurveOrder sort_by_curve(Backend& backend, const Aabb* boxes, uint32_t n, const Aabb* bounds,
                         Curve curve);

}  // namespace caustica
