#include "renderer/accel/triangle_bvh.h"

#include "renderer/base/morton.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

TriangleBvh build_triangle_bvh(Backend& backend, const TriangleVertices* triangles, uint32_t count) {
  TriangleBvh out;
  out.triangles.bind(backend);
  out.triangle_ids.bind(backend);
  if (count == 0) {
    out.bvh.nodes.bind(backend);
    return out;
  }
  // Pass 1: triangle boxes, and centroid points whose reduction is the box the codes quantise.
  Buffer<Aabb> boxes(backend, count);
  Buffer<Aabb> centroids(backend, count);
  Aabb* box = boxes.data();
  Aabb* centroid = centroids.data();
  parallel_for(backend, count, [=] CAUSTICA_HD(size_t i) {
    const TriangleVertices& t = triangles[i];
    Aabb b;
    b.extend(t.p0);
    b.extend(t.p1);
    b.extend(t.p2);
    box[i] = b;
    Vec3f c = b.center();
    centroid[i] = Aabb{c, c};
  });
  const Aabb scene_bounds = backend.reduce_bounds(box, count);
  const Aabb centroid_bounds = backend.reduce_bounds(centroid, count);

  // Pass 2: Morton codes, sorted with the triangle indices.
  Buffer<uint32_t> codes(backend, count);
  out.triangle_ids.resize_discard(count);
  uint32_t* code = codes.data();
  uint32_t* ids = out.triangle_ids.data();
  parallel_for(backend, count, [=] CAUSTICA_HD(size_t i) {
    code[i] = morton_code(centroid[i].lower, centroid_bounds);
    ids[i] = uint32_t(i);
  });
  backend.sort_pairs(code, ids, count, 30);

  // Pass 3: triangles and boxes gathered into leaf order (boxes reuse the centroid buffer).
  out.triangles.resize_discard(count);
  TriangleVertices* sorted = out.triangles.data();
  Aabb* sorted_box = centroids.data();
  parallel_for(backend, count, [=] CAUSTICA_HD(size_t i) {
    sorted[i] = triangles[ids[i]];
    sorted_box[i] = box[ids[i]];
  });
  out.bvh = build_bvh_from_sorted_codes(backend, code, sorted_box, count, scene_bounds);
  return out;
}

}  // namespace caustica
