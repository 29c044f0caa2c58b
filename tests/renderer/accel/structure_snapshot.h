// A structure's tree written out in an order that depends only on its shape: the same tree built
// twice, or on two backends, gives the same words even where node numbers came from atomic
// counters (bvh8's builders).
#pragma once

#include <algorithm>
#include <cstring>
#include <type_traits>
#include <vector>

#include "renderer/accel/structure.h"

namespace caustica {

namespace detail {

template <typename T>
std::vector<T> fetch(Backend& backend, const T* p, size_t n) {
  std::vector<T> out(n);
  if (n) backend.copy_to_host(out.data(), p, n * sizeof(T));
  return out;
}

inline void append_words(std::vector<uint32_t>& out, const void* p, size_t bytes) {
  const size_t at = out.size();
  out.resize(at + bytes / 4);
  std::memcpy(out.data() + at, p, bytes);
}

}  // namespace detail

// Layouts whose builders number nodes in an order fixed by the tree (level by level, or
// depth first) are their own canonical form: their nodes' and ids' bytes.
template <typename View>
std::vector<uint32_t> structure_snapshot(Backend& backend, const View& v, size_t nodes) {
  using Node = std::remove_cv_t<std::remove_pointer_t<decltype(v.nodes)>>;
  std::vector<uint32_t> out;
  const auto n = detail::fetch(backend, v.nodes, nodes);
  const auto ids = detail::fetch(backend, v.triangle_ids, v.count);
  detail::append_words(out, n.data(), n.size() * sizeof(Node));
  detail::append_words(out, ids.data(), ids.size() * sizeof(uint32_t));
  return out;
}

// A kd-tree's nodes (numbered level by level) and its leaves' references, as far as the leaves
// reach.
template <KdTraversal kTraversal>
std::vector<uint32_t> structure_snapshot(Backend& backend, const KdTreeView<kTraversal>& v,
                                         size_t nodes) {
  std::vector<uint32_t> out;
  const auto n = detail::fetch(backend, v.nodes, nodes);
  size_t refs = 0;
  for (const KdNode& node : n)
    if (node.leaf()) refs = std::max<size_t>(refs, size_t(node.first_ref()) + node.ref_count());
  const auto r = detail::fetch(backend, v.refs, refs);
  detail::append_words(out, n.data(), n.size() * sizeof(KdNode));
  detail::append_words(out, r.data(), r.size() * sizeof(uint32_t));
  return out;
}

// Depth first from the root in slot order: each node's grid, metas and quantised boxes, with its
// leaves' original triangle ids in place of its base indices.
inline std::vector<uint32_t> structure_snapshot(Backend& backend, const Bvh8View& v, size_t nodes) {
  std::vector<uint32_t> out;
  if (v.count == 0) return out;
  const auto n = detail::fetch(backend, v.nodes, nodes);
  const auto ids = detail::fetch(backend, v.triangle_ids, v.count);
  std::vector<uint32_t> todo{0};
  while (!todo.empty()) {
    const Bvh8Node node = n.at(todo.back());
    todo.pop_back();
    Bvh8Node shape = node;
    shape.child_base = shape.triangle_base = 0;
    detail::append_words(out, &shape, sizeof shape);
    uint32_t rank = 0;
    for (int s = 0; s < 8; ++s) {
      if (bvh8_slot_is_internal(node.meta[s])) {
        todo.push_back(node.child_base + rank++);
      } else {
        for (uint32_t k = 0; k < bvh8_leaf_triangles(node.meta[s]); ++k)
          out.push_back(ids.at(node.triangle_base + (node.meta[s] & 31u) + k));
      }
    }
  }
  return out;
}

}  // namespace caustica
