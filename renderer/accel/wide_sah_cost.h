// The SAH cost (StructureStats::sah_cost, C_T = C_I = 1) of a BVH whose nodes each hold their
// children's boxes (the 4-wide and the 8-wide layouts): 1 for the root, plus per node the sum of
// its children's terms, an inner child's box area and a leaf's triangles times its box area, all
// relative to the root's area.
#pragma once

#include "renderer/parallel/buffer.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

// `children_terms(node, inv_root_area)` gives a node's sum; `launch` names the launch. A tree of
// no triangles or of a flat root costs its triangles, one triangle 1.
template <typename Node, typename ChildrenTerms>
double wide_sah_cost(Backend& backend, const char* launch, const Node* nodes, size_t node_count,
                     uint32_t triangles, float root_area, ChildrenTerms children_terms) {
  if (triangles == 0 || !(root_area > 0.0f)) return double(triangles);
  if (triangles == 1) return 1.0;
  Buffer<float> terms(backend, node_count);
  float* term = terms.data();
  const float inv_root = 1.0f / root_area;
  parallel_for(backend, launch, node_count,
               [=] CAUSTICA_HD(size_t i) { term[i] = children_terms(nodes[i], inv_root); });
  return 1.0 + backend.reduce_sum(term, node_count);
}

}  // namespace caustica
