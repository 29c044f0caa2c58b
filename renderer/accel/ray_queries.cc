// The one instantiation of each per-ray view's batch queries (structure.h says why).
#include "renderer/accel/ray_queries.h"

#include "renderer/accel/structure.h"

namespace caustica {

#define CAUSTICA_BATCH_QUERIES(View)                                                  \
  template void trace_closest<View>(Backend&, const View&, const Ray*, size_t, Hit*); \
  template void trace_any<View>(Backend&, const View&, const Ray*, size_t, uint8_t*);
CAUSTICA_FOR_EACH_STRUCTURE_VIEW(CAUSTICA_BATCH_QUERIES)
#undef CAUSTICA_BATCH_QUERIES

}  // namespace caustica
