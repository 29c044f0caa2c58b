#include "renderer/accel/morton_order.h"

#include "renderer/base/morton.h"

namespace caustica {

MortonOrder sort_by_morton(Backend& backend, const Aabb* boxes, uint32_t n, const Aabb* bounds) {
  return sort_by_code(backend, n, 31,
                      [=] CAUSTICA_HD(uint32_t i) { return extended_morton_code(boxes[i], *bounds); });
}

}  // namespace caustica
