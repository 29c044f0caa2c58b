#include "renderer/accel/morton_order.h"

#include "renderer/base/morton.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

MortonOrder sort_by_morton(Backend& backend, const Aabb* boxes, uint32_t n, const Aabb* bounds) {
  MortonOrder out{Buffer<uint32_t>(backend, n), Buffer<uint32_t>(backend, n)};
  uint32_t* code = out.codes.data();
  uint32_t* id = out.order.data();
  parallel_for(backend, n, [=] CAUSTICA_HD(size_t i) {
    code[i] = extended_morton_code(boxes[i], *bounds);
    id[i] = uint32_t(i);
  });
  backend.sort_pairs(code, id, n, 31);
  return out;
}

}  // namespace caustica
