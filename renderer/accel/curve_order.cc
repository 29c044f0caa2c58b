#include "renderer/accel/curve_order.h"

namespace caustica {

Curve backend_curve(const Backend& backend) {
  return backend.kind() == DeviceKind::kCuda ? Curve::kHilbert : Curve::kMorton;
}

CurveOrder sort_by_curve(Backend& backend, const Aabb* boxes, uint32_t n, const Aabb* bounds,
                         Curve curve) {
  return sort_by_code(backend, n, kCurveCodeBits,
                      [=] CAUSTICA_HD(uint32_t i) { return curve_code(curve, boxes[i], *bounds); });
}

}  // namespace caustica
