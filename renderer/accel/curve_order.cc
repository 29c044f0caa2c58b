#include "renderer/accel/curve_order.h"

#include "renderer/base/morton.h"

namespace caustica {

Curve backend_curve(const Backend& backend) {
  return backend.kind() == DeviceKind::kCuda ? Curve::kHilbert : Curve::kMorton;
}

CurveOrder sort_by_curve(Backend& backend, const Aabb* boxes, uint32_t n, const Aabb* bounds,
                         Curve curve) {
  return sort_by_code(backend, n, 31, [=] CAUSTICA_HD(uint32_t i) {
    return curve == Curve::kHilbert ? extended_hilbert_code(boxes[i], *bounds)
                                    : extended_morton_code(boxes[i], *bounds);
  });
}

}  // namespace caustica
