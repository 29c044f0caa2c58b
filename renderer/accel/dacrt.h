// Parallel divide-and-conquer ray tracing (Ravichandran and Narayanan 2013): no acceleration
// structure is kept between frames. Every batch of rays is traced by dividing (triangles, rays)
// breadth-first over space: each level splits every node's box at the midpoint of its largest
// extent, classifies its triangles (left, right or both) and its rays (left, right, both or
// neither) one thread per element, and gathers the next level's elements with scans; nodes
// small enough in triangles or in rays become terminal and their rays are tested against their
// triangles by brute force with the exact triangle tests of triangle.h, the nearest hit per ray
// taken by an atomic minimum over (t, triangle) keys. So the layout below stores only the
// triangles and their boxes, and its view answers batches only (trace_closest, trace_any), not
// the per-ray StructureView (docs/structures.md, "dacrt").
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "renderer/accel/triangle.h"
#include "renderer/parallel/buffer.h"

namespace caustica {

// When a node stops being divided. The paper's rule, a node with fewer than 256 triangles or
// fewer than 256 rays is brute-forced, with one guard: a node whose brute force would take more
// than max_terminal_tests ray-triangle tests is divided further anyway (a few rays through a
// dense region, or many rays through a few large triangles, would otherwise cost as much as
// thousands of ordinary nodes), unless the split that made it sent every triangle of its parent
// to both children (coincident triangles, which splits copy without end). A node whose box is
// down to a few times the boxes' padding (dacrt.cc), or at max_depth, ends whatever it holds.
struct DacrtSettings {
  uint32_t terminal_triangles = 256;
  uint32_t terminal_rays = 256;
  uint64_t max_terminal_tests = uint64_t(256) * 4096;
  uint32_t max_depth = 40;
};

// Plain pointers into a DacrtTriangles, copied by value; answers batches only.
struct DacrtView {
  const TriangleVertices* triangles = nullptr;  // in the order the structure was given them
  const Aabb* triangle_bounds = nullptr;
  uint32_t count = 0;
  Aabb bounds;
  DacrtSettings settings;
};

// The stored part of DACRT: the triangles as given and their boxes.
struct DacrtTriangles {
  Buffer<TriangleVertices> triangles;
  Buffer<Aabb> triangle_bounds;
  Aabb bounds;
  DacrtSettings settings;

  DacrtView view() const {
    return {triangles.data(), triangle_bounds.data(), uint32_t(triangles.size()), bounds, settings};
  }
  size_t node_count() const { return 0; }
  size_t bytes() const { return triangles.bytes() + triangle_bounds.bytes(); }
};

// Copies `count` triangles already in the backend's memory and computes their boxes.
DacrtTriangles build_dacrt_triangles(Backend& backend, const TriangleVertices* triangles,
                                     uint32_t count, const DacrtSettings& settings = {});

// What one batch cost: the division's levels, its terminal nodes, the ray-triangle tests their
// brute force made, and the most scratch memory the batch held at once (what DACRT uses instead
// of a stored structure).
struct DacrtTraceStats {
  uint32_t levels = 0;
  size_t terminal_nodes = 0;
  uint64_t triangle_tests = 0;
  size_t peak_scratch_bytes = 0;
};

// The batch queries (ray_queries.h) for DACRT; `stats`, when given, receives what the batch cost.
void trace_closest(Backend& backend, const DacrtView& view, const Ray* rays, size_t count,
                   Hit* hits, DacrtTraceStats* stats);
void trace_any(Backend& backend, const DacrtView& view, const Ray* rays, size_t count,
               uint8_t* blocked, DacrtTraceStats* stats);
inline void trace_closest(Backend& backend, const DacrtView& view, const Ray* rays, size_t count,
                          Hit* hits) {
  trace_closest(backend, view, rays, count, hits, nullptr);
}
inline void trace_any(Backend& backend, const DacrtView& view, const Ray* rays, size_t count,
                      uint8_t* blocked) {
  trace_any(backend, view, rays, count, blocked, nullptr);
}

// The division alone, for tests: every terminal node's triangles and rays, with no ray culled by
// a hit found on the way (the queries above drop a ray from nodes behind its nearest hit so far,
// and a blocked shadow ray from every node).
struct DacrtTerminal {
  std::vector<uint32_t> triangles;
  std::vector<uint32_t> rays;
};
std::vector<DacrtTerminal> dacrt_terminal_nodes(Backend& backend, const DacrtView& view,
                                                const Ray* rays, size_t count);

}  // namespace caustica
