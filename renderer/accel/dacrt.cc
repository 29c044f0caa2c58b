#include "renderer/accel/dacrt.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "renderer/base/atomic.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

enum class Query { kClosest, kAny, kDivide };

// What a node of a level becomes.
enum : uint8_t { kDiscarded = 0, kTerminal = 1, kActive = 2 };

// A hit as one 64-bit key: t's bits high (t > t_min >= 0, so its bits order as it does) and the
// triangle low, so that the smallest key is the nearest hit and, among exact ties, the lowest
// triangle index, which is what brute force over the triangles in order finds.
constexpr uint64_t kNoHitKey = ~uint64_t(0);

CAUSTICA_HDI uint64_t hit_key(float t, uint32_t triangle) {
  uint32_t bits;
  memcpy(&bits, &t, sizeof bits);
  return (uint64_t(bits) << 32) | triangle;
}

CAUSTICA_HDI float key_distance(uint64_t key) {
  const uint32_t bits = uint32_t(key >> 32);
  float t;
  memcpy(&t, &bits, sizeof t);
  return t;
}

CAUSTICA_HDI void atomic_min_key(uint64_t* p, uint64_t v) {
#if defined(__CUDA_ARCH__)
  atomicMin(reinterpret_cast<unsigned long long*>(p), static_cast<unsigned long long>(v));
#else
  std::atomic_ref<uint64_t> a(*p);
  uint64_t old = a.load(std::memory_order_relaxed);
  while (v < old && !a.compare_exchange_weak(old, v, std::memory_order_relaxed)) {
  }
#endif
}

struct Split {
  int axis;
  float position;
};

// The midpoint of the box's largest extent (the paper's split).
CAUSTICA_HDI Split split_of(const Aabb& box) {
  const int axis = max_dimension(box.extent());
  return {axis, 0.5f * (box.lower[axis] + box.upper[axis])};
}

// A child's box: the parent's cut at the split, grown by `pad` past it so that rounding in the
// rays' slab tests never drops a ray from a box holding one of its hits.
CAUSTICA_HDI Aabb child_box(Aabb box, Split s, int side, float pad) {
  if (side == 0) {
    box.upper[s.axis] = fminf(box.upper[s.axis], s.position + pad);
  } else {
    box.lower[s.axis] = fmaxf(box.lower[s.axis], s.position - pad);
  }
  return box;
}

// Whether the segment (t0, t1) of `ray` meets the closed box. A direction component too small
// for its reciprocal leaves that axis unconstrained: taking a ray into one box too many costs
// tests, never answers.
CAUSTICA_HDI bool segment_meets_box(const Ray& ray, float t0, float t1, const Aabb& box) {
  for (int k = 0; k < 3; ++k) {
    const float d = ray.direction[k];
    if (!(fabsf(d) >= 1e-30f)) continue;
    const float inv = 1.0f / d;
    const float ta = (box.lower[k] - ray.origin[k]) * inv;
    const float tb = (box.upper[k] - ray.origin[k]) * inv;
    t0 = fmaxf(t0, fminf(ta, tb));
    t1 = fminf(t1, fmaxf(ta, tb));
  }
  return t0 <= t1;
}

// Which of the two children of `box` split at `split` the segment (t0, t1) of `ray` meets: the
// answers of segment_meets_box for both child boxes, with the two axes they share tested once.
CAUSTICA_HDI void children_met(const Ray& ray, float t0, float t1, const Aabb& box, Split split,
                               float pad, uint32_t& left, uint32_t& right) {
  for (int k = 0; k < 3; ++k) {
    const float d = ray.direction[k];
    if (k == split.axis || !(fabsf(d) >= 1e-30f)) continue;
    const float inv = 1.0f / d;
    const float ta = (box.lower[k] - ray.origin[k]) * inv;
    const float tb = (box.upper[k] - ray.origin[k]) * inv;
    t0 = fmaxf(t0, fminf(ta, tb));
    t1 = fminf(t1, fmaxf(ta, tb));
  }
  left = right = 0;
  if (!(t0 <= t1)) return;
  const int a = split.axis;
  const float d = ray.direction[a];
  if (!(fabsf(d) >= 1e-30f)) {
    left = right = 1;
    return;
  }
  const float inv = 1.0f / d, o = ray.origin[a];
  const float t_lower = (box.lower[a] - o) * inv, t_upper = (box.upper[a] - o) * inv;
  const float t_left_end = (fminf(box.upper[a], split.position + pad) - o) * inv;
  const float t_right_start = (fmaxf(box.lower[a], split.position - pad) - o) * inv;
  left = fmaxf(t0, fminf(t_lower, t_left_end)) <= fminf(t1, fmaxf(t_lower, t_left_end)) ? 1u : 0u;
  right = fmaxf(t0, fminf(t_right_start, t_upper)) <= fminf(t1, fmaxf(t_right_start, t_upper))
              ? 1u
              : 0u;
}

// The padding of every box: a relative 1e-5 of the scene's largest coordinate or extent, far
// above the slab tests' rounding and the watertight test's own.
float box_padding(const Aabb& b) {
  const float scale = std::max({max_component(abs(b.lower)), max_component(abs(b.upper)),
                                max_component(b.extent())});
  return 1e-5f * scale + 1e-30f;
}

// One level's nodes and the elements in them. Elements are sorted by node: node c holds the
// triangle references [tri_first[c], tri_first[c] + tris[c]) and the ray references likewise.
struct Level {
  size_t nodes = 0, tri_refs = 0, ray_refs = 0;
  Buffer<Aabb> box;
  Buffer<uint32_t> tris, rays, tri_first, ray_first;
  // 1 when the split that made the node left some triangle out of one of its two children.
  Buffer<uint8_t> separated;
  Buffer<uint32_t> tri_node, tri_id, ray_node, ray_id;

  explicit Level(Backend& b)
      : box(b, 0), tris(b, 0), rays(b, 0), tri_first(b, 0), ray_first(b, 0), separated(b, 0),
        tri_node(b, 0), tri_id(b, 0), ray_node(b, 0), ray_id(b, 0) {}
  void resize_nodes(size_t n) {
    nodes = n;
    box.resize_discard(n);
    separated.resize_discard(n);
    tris.resize_discard(n);
    rays.resize_discard(n);
    tri_first.resize_discard(n);
    ray_first.resize_discard(n);
  }
  void resize_tri_refs(size_t n) {
    tri_refs = n;
    tri_node.resize_discard(n);
    tri_id.resize_discard(n);
  }
  void resize_ray_refs(size_t n) {
    ray_refs = n;
    ray_node.resize_discard(n);
    ray_id.resize_discard(n);
  }
};

// What a level's division needs besides the two levels: node kinds and new ids, and the scans
// that place each element in its children.
struct DivisionScratch {
  Buffer<uint8_t> kind, terminal_ray_flag;
  Buffer<uint32_t> active_id, terminal_rays;
  Buffer<uint32_t> tri_left, tri_right, ray_left, ray_right;  // flags, then their exclusive scans
  Buffer<uint32_t> tests, terminal_flag;  // for DacrtTraceStats
  explicit DivisionScratch(Backend& b)
      : kind(b, 0), terminal_ray_flag(b, 0), active_id(b, 0), terminal_rays(b, 0), tri_left(b, 0),
        tri_right(b, 0), ray_left(b, 0), ray_right(b, 0), tests(b, 0), terminal_flag(b, 0) {}
};

// The refs arrays' scans count in 32 bits; a level may at most double its references.
void check_reference_count(size_t refs, const char* what) {
  if (refs >= (size_t(1) << 31)) {
    throw DeviceError(std::string("dacrt: too many ") + what +
                      " references for one level (at most 2^31)");
  }
}

// The root: every triangle, and the rays whose segment meets the scene's box.
void make_root(Backend& backend, const DacrtView& view, const Ray* rays, size_t count, float pad,
               Level& root, DivisionScratch& s) {
  root.resize_nodes(1);
  Aabb box = view.bounds;
  box.lower = box.lower - Vec3f(pad);
  box.upper = box.upper + Vec3f(pad);
  root.resize_tri_refs(view.count);
  uint32_t* tri_node = root.tri_node.data();
  uint32_t* tri_id = root.tri_id.data();
  parallel_for(backend, "dacrt_root_triangles", view.count, [=] CAUSTICA_HD(size_t i) {
    tri_node[i] = 0;
    tri_id[i] = uint32_t(i);
  });
  s.terminal_ray_flag.resize_discard(count);
  uint8_t* meets = s.terminal_ray_flag.data();
  parallel_for(backend, "dacrt_root_rays", count, [=] CAUSTICA_HD(size_t i) {
    const Ray r = rays[i];
    meets[i] = r.t_min < r.t_max && segment_meets_box(r, r.t_min, r.t_max, box) ? 1 : 0;
  });
  root.ray_id.resize_discard(count);
  const size_t selected = backend.select_flagged(nullptr, meets, count, root.ray_id.data());
  root.resize_ray_refs(selected);
  root.ray_node.fill_zero();
  const uint32_t tris = view.count, ray_refs = uint32_t(selected);
  Aabb* root_box = root.box.data();
  uint32_t *tri_count = root.tris.data(), *ray_count = root.rays.data();
  uint32_t *tri_first = root.tri_first.data(), *ray_first = root.ray_first.data();
  uint8_t* separated = root.separated.data();
  parallel_for(backend, "dacrt_root_node", 1, [=] CAUSTICA_HD(size_t) {
    root_box[0] = box;
    separated[0] = 1;
    tri_count[0] = tris;
    ray_count[0] = ray_refs;
    tri_first[0] = 0;
    ray_first[0] = 0;
  });
}

// Where each node of `level` goes: nowhere (no triangles or no rays), to brute force, or on to
// the next level. Returns the number of active nodes; active_id numbers them in order.
size_t decide_nodes(Backend& backend, const DacrtSettings& settings, uint32_t depth, float pad,
                    const Level& level, DivisionScratch& s) {
  const size_t n = level.nodes;
  s.kind.resize_discard(n);
  s.active_id.resize_discard(n);
  s.terminal_flag.resize_discard(n);
  uint8_t* kind = s.kind.data();
  uint32_t* active = s.active_id.data();
  uint32_t* terminal = s.terminal_flag.data();
  const uint32_t* tris = level.tris.data();
  const uint32_t* rays = level.rays.data();
  const uint8_t* separated = level.separated.data();
  const Aabb* box = level.box.data();
  // A box this small has children no smaller than itself but for the padding, which a split
  // would copy every element into.
  const float smallest_divided = 16.0f * pad;
  const DacrtSettings cfg = settings;
  parallel_for(backend, "dacrt_decide_nodes", n, [=] CAUSTICA_HD(size_t c) {
    const uint32_t t = tris[c], r = rays[c];
    uint8_t k = kActive;
    if (t == 0 || r == 0) {
      k = kDiscarded;
    } else if (depth >= cfg.max_depth || max_component(box[c].extent()) < smallest_divided) {
      k = kTerminal;
    } else if ((t < cfg.terminal_triangles || r < cfg.terminal_rays) &&
               (uint64_t(t) * r <= cfg.max_terminal_tests || !separated[c])) {
      k = kTerminal;
    }
    kind[c] = k;
    active[c] = k == kActive ? 1u : 0u;
    terminal[c] = k == kTerminal ? 1u : 0u;
  });
  return backend.exclusive_scan(active, active, n);
}

// The ray references of `level` that lie in terminal nodes, compacted; returns how many.
size_t select_terminal_rays(Backend& backend, const Level& level, DivisionScratch& s) {
  s.terminal_ray_flag.resize_discard(level.ray_refs);
  s.terminal_rays.resize_discard(level.ray_refs);
  uint8_t* flag = s.terminal_ray_flag.data();
  const uint8_t* kind = s.kind.data();
  const uint32_t* ray_node = level.ray_node.data();
  parallel_for(backend, "dacrt_terminal_ray_flags", level.ray_refs, [=] CAUSTICA_HD(size_t i) {
    flag[i] = kind[ray_node[i]] == kTerminal ? 1 : 0;
  });
  return backend.select_flagged(nullptr, flag, level.ray_refs, s.terminal_rays.data());
}

// Brute force in the terminal nodes: each terminal ray reference against its node's triangles.
// Closest hits lower the ray's key; any hits set its blocked word and stop.
template <Query kQuery>
void brute_force_terminals(Backend& backend, const DacrtView& view, const Ray* rays,
                           const Level& level, size_t terminal_refs, DivisionScratch& s,
                           uint64_t* best, uint32_t* blocked, bool count_tests) {
  const uint32_t* selected = s.terminal_rays.data();
  const uint32_t* ray_node = level.ray_node.data();
  const uint32_t* ray_id = level.ray_id.data();
  const uint32_t* tri_first = level.tri_first.data();
  const uint32_t* tris = level.tris.data();
  const uint32_t* tri_id = level.tri_id.data();
  const TriangleVertices* triangles = view.triangles;
  s.tests.resize_discard(count_tests ? terminal_refs : 0);
  uint32_t* tests = count_tests ? s.tests.data() : nullptr;
  parallel_for(backend, "dacrt_brute_force", terminal_refs, [=] CAUSTICA_HD(size_t j) {
    const uint32_t ref = selected[j];
    const uint32_t node = ray_node[ref], r = ray_id[ref];
    const uint32_t first = tri_first[node], end = first + tris[node];
    if (tests != nullptr) tests[j] = end - first;
    const Ray ray = rays[r];
    const WatertightRay w(ray);
    // A plain `if` on the template's constant: nvcc's extended lambdas may not first capture a
    // variable inside `if constexpr`.
    if (kQuery == Query::kClosest) {
      uint64_t nearest = kNoHitKey;
      for (uint32_t k = first; k < end; ++k) {
        const uint32_t tri = tri_id[k];
        float t, u, v;
        if (intersect_triangle(w, triangles[tri], ray.t_min, ray.t_max, t, u, v)) {
          const uint64_t key = hit_key(t, tri);
          nearest = key < nearest ? key : nearest;
        }
      }
      if (nearest != kNoHitKey) atomic_min_key(best + r, nearest);
    } else {
      for (uint32_t k = first; k < end; ++k) {
        if (triangle_blocks(w, triangles[tri_id[k]], ray.t_min, ray.t_max)) {
          atomic_exchange(blocked + r, 1u);
          break;
        }
      }
    }
  });
}

// Places reference i (of id `id`, in a node of `count` references from `first` on, active as
// node `a`) in the children it goes to: `left` and `right` are the exclusive scans of the
// references going left and right, so each child keeps its references in their order, the left
// child's before the right's.
CAUSTICA_HDI void gather_split_reference(size_t i, const uint32_t* left, const uint32_t* right,
                                         uint32_t first, uint32_t count, uint32_t a, uint32_t id,
                                         uint32_t* next_node, uint32_t* next_id) {
  const bool goes_left = left[i + 1] != left[i], goes_right = right[i + 1] != right[i];
  if (goes_left) {
    const uint32_t at = right[first] + left[i];
    next_node[at] = 2 * a;
    next_id[at] = id;
  }
  if (goes_right) {
    const uint32_t at = left[first + count] + right[i];
    next_node[at] = 2 * a + 1;
    next_id[at] = id;
  }
}

// Splits every active node of `level` into two nodes of `next`: triangles left of, right of or
// across the split, rays into the children their segment meets. kQuery kClosest leaves a ray out
// of children behind its nearest hit so far, kAny leaves blocked rays out altogether.
template <Query kQuery>
void divide_level(Backend& backend, const DacrtView& view, const Ray* rays, float pad,
                  const Level& level, size_t active_nodes, Level& next, DivisionScratch& s,
                  const uint64_t* best, const uint32_t* blocked) {
  check_reference_count(level.tri_refs, "triangle");
  check_reference_count(level.ray_refs, "ray");
  const uint8_t* kind = s.kind.data();
  const uint32_t* active_id = s.active_id.data();
  const Aabb* box = level.box.data();
  const uint32_t* tri_node = level.tri_node.data();
  const uint32_t* tri_id = level.tri_id.data();
  const uint32_t* ray_node = level.ray_node.data();
  const uint32_t* ray_id = level.ray_id.data();
  const Aabb* tri_bounds = view.triangle_bounds;

  // One slot past the last reference, so that the scans also give each node's end.
  s.tri_left.resize_discard(level.tri_refs + 1);
  s.tri_right.resize_discard(level.tri_refs + 1);
  s.ray_left.resize_discard(level.ray_refs + 1);
  s.ray_right.resize_discard(level.ray_refs + 1);
  uint32_t *tri_left = s.tri_left.data(), *tri_right = s.tri_right.data();
  uint32_t *ray_left = s.ray_left.data(), *ray_right = s.ray_right.data();
  const size_t tri_refs = level.tri_refs, ray_refs = level.ray_refs;
  parallel_for(backend, "dacrt_classify_triangles", tri_refs + 1, [=] CAUSTICA_HD(size_t i) {
    uint32_t left = 0, right = 0;
    if (i < tri_refs && kind[tri_node[i]] == kActive) {
      const Split split = split_of(box[tri_node[i]]);
      const Aabb b = tri_bounds[tri_id[i]];
      left = b.lower[split.axis] <= split.position ? 1u : 0u;
      right = b.upper[split.axis] >= split.position ? 1u : 0u;
    }
    tri_left[i] = left;
    tri_right[i] = right;
  });
  parallel_for(backend, "dacrt_classify_rays", ray_refs + 1, [=] CAUSTICA_HD(size_t i) {
    uint32_t left = 0, right = 0;
    if (i < ray_refs && kind[ray_node[i]] == kActive) {
      const uint32_t r = ray_id[i];
      const Ray ray = rays[r];
      float t_max = ray.t_max;
      bool carried = true;
      if (kQuery == Query::kClosest) {
        // Ties at the nearest distance so far stay: a lower triangle index may still win them.
        const uint64_t key = best[r];
        if (key != kNoHitKey) t_max = fminf(t_max, key_distance(key));
      } else if (kQuery == Query::kAny) {
        carried = blocked[r] == 0;
      }
      if (carried) {
        const Aabb b = box[ray_node[i]];
        const Split split = split_of(b);
        children_met(ray, ray.t_min, t_max, b, split, pad, left, right);
      }
    }
    ray_left[i] = left;
    ray_right[i] = right;
  });
  const size_t next_tri_refs = size_t(backend.exclusive_scan(tri_left, tri_left, tri_refs + 1)) +
                               backend.exclusive_scan(tri_right, tri_right, tri_refs + 1);
  const size_t next_ray_refs = size_t(backend.exclusive_scan(ray_left, ray_left, ray_refs + 1)) +
                               backend.exclusive_scan(ray_right, ray_right, ray_refs + 1);

  // Each active node's children take its references in order, the left child's first: a left
  // reference i of node c goes to (right references before c) + (left references before i), a
  // right one to (left references up to c's end) + (right references before i).
  next.resize_nodes(2 * active_nodes);
  next.resize_tri_refs(next_tri_refs);
  next.resize_ray_refs(next_ray_refs);
  Aabb* next_box = next.box.data();
  uint32_t *next_tris = next.tris.data(), *next_rays = next.rays.data();
  uint32_t *next_tri_first = next.tri_first.data(), *next_ray_first = next.ray_first.data();
  uint8_t* next_separated = next.separated.data();
  const uint32_t* tris = level.tris.data();
  const uint32_t* rays_in = level.rays.data();
  const uint32_t* tri_first = level.tri_first.data();
  const uint32_t* ray_first = level.ray_first.data();
  parallel_for(backend, "dacrt_child_nodes", level.nodes, [=] CAUSTICA_HD(size_t c) {
    if (kind[c] != kActive) return;
    const uint32_t a = active_id[c];
    const Aabb b = box[c];
    const Split split = split_of(b);
    next_box[2 * a] = child_box(b, split, 0, pad);
    next_box[2 * a + 1] = child_box(b, split, 1, pad);
    const uint32_t ts = tri_first[c], te = ts + tris[c];
    const uint32_t tri_left_count = tri_left[te] - tri_left[ts];
    next_tri_first[2 * a] = tri_left[ts] + tri_right[ts];
    next_tris[2 * a] = tri_left_count;
    next_tri_first[2 * a + 1] = tri_left[ts] + tri_right[ts] + tri_left_count;
    next_tris[2 * a + 1] = tri_right[te] - tri_right[ts];
    const uint8_t split_separates = tri_left_count < tris[c] || next_tris[2 * a + 1] < tris[c];
    next_separated[2 * a] = next_separated[2 * a + 1] = split_separates;
    const uint32_t rs = ray_first[c], re = rs + rays_in[c];
    const uint32_t ray_left_count = ray_left[re] - ray_left[rs];
    next_ray_first[2 * a] = ray_left[rs] + ray_right[rs];
    next_rays[2 * a] = ray_left_count;
    next_ray_first[2 * a + 1] = ray_left[rs] + ray_right[rs] + ray_left_count;
    next_rays[2 * a + 1] = ray_right[re] - ray_right[rs];
  });
  uint32_t *next_tri_node = next.tri_node.data(), *next_tri_id = next.tri_id.data();
  parallel_for(backend, "dacrt_gather_triangles", tri_refs, [=] CAUSTICA_HD(size_t i) {
    const uint32_t c = tri_node[i];
    gather_split_reference(i, tri_left, tri_right, tri_first[c], tris[c], active_id[c], tri_id[i],
                           next_tri_node, next_tri_id);
  });
  uint32_t *next_ray_node = next.ray_node.data(), *next_ray_id = next.ray_id.data();
  parallel_for(backend, "dacrt_gather_rays", ray_refs, [=] CAUSTICA_HD(size_t i) {
    const uint32_t c = ray_node[i];
    gather_split_reference(i, ray_left, ray_right, ray_first[c], rays_in[c], active_id[c],
                           ray_id[i], next_ray_node, next_ray_id);
  });
}

// The terminal nodes of `level`, read back for dacrt_terminal_nodes.
void record_terminals(const Level& level, const DivisionScratch& s,
                      std::vector<DacrtTerminal>& out) {
  const std::vector<uint8_t> kind = s.kind.download();
  const std::vector<uint32_t> tris = level.tris.download(), rays = level.rays.download();
  const std::vector<uint32_t> tri_first = level.tri_first.download();
  const std::vector<uint32_t> ray_first = level.ray_first.download();
  const std::vector<uint32_t> tri_id = level.tri_id.download(), ray_id = level.ray_id.download();
  for (size_t c = 0; c < level.nodes; ++c) {
    if (kind[c] != kTerminal) continue;
    DacrtTerminal t;
    t.triangles.assign(tri_id.begin() + tri_first[c], tri_id.begin() + tri_first[c] + tris[c]);
    t.rays.assign(ray_id.begin() + ray_first[c], ray_id.begin() + ray_first[c] + rays[c]);
    out.push_back(std::move(t));
  }
}

// The whole division of one batch, brute-forcing each level's terminal nodes as it goes.
template <Query kQuery>
void divide_and_conquer(Backend& backend, const DacrtView& view, const Ray* rays, size_t count,
                        uint64_t* best, uint32_t* blocked, DacrtTraceStats* stats,
                        std::vector<DacrtTerminal>* terminals) {
  if (count >= (size_t(1) << 31)) throw DeviceError("dacrt: more than 2^31 rays in one batch");
  const size_t start_bytes = backend.bytes_in_use();
  size_t peak = 0;
  auto note_memory = [&] { peak = std::max(peak, backend.bytes_in_use() - start_bytes); };
  DacrtTraceStats local;
  if (view.count == 0 || count == 0) {
    if (stats != nullptr) *stats = local;
    return;
  }
  const float pad = box_padding(view.bounds);
  Level levels[2] = {Level(backend), Level(backend)};
  DivisionScratch scratch(backend);
  make_root(backend, view, rays, count, pad, levels[0], scratch);
  for (uint32_t depth = 0;; ++depth) {
    Level& level = levels[depth % 2];
    Level& next = levels[(depth + 1) % 2];
    ++local.levels;
    const size_t active = decide_nodes(backend, view.settings, depth, pad, level, scratch);
    if (terminals != nullptr) {
      record_terminals(level, scratch, *terminals);
    } else {
      const size_t terminal_refs = select_terminal_rays(backend, level, scratch);
      brute_force_terminals<kQuery>(backend, view, rays, level, terminal_refs, scratch, best,
                                    blocked, stats != nullptr);
      if (stats != nullptr) {
        local.triangle_tests += backend.reduce_sum(scratch.tests.data(), terminal_refs);
        local.terminal_nodes += backend.reduce_sum(scratch.terminal_flag.data(), level.nodes);
      }
    }
    note_memory();
    if (active == 0) break;
    divide_level<kQuery>(backend, view, rays, pad, level, active, next, scratch, best, blocked);
    note_memory();
  }
  if (stats != nullptr) {
    local.peak_scratch_bytes = peak;
    *stats = local;
  }
}

}  // namespace

DacrtTriangles build_dacrt_triangles(Backend& backend, const TriangleVertices* triangles,
                                     uint32_t count, const DacrtSettings& settings) {
  DacrtTriangles out{Buffer<TriangleVertices>(backend, count), Buffer<Aabb>(backend, count),
                     Aabb{}, settings};
  if (count == 0) return out;
  backend.copy_on_device(out.triangles.data(), triangles, size_t(count) * sizeof(TriangleVertices));
  Aabb* bounds = out.triangle_bounds.data();
  const TriangleVertices* tris = out.triangles.data();
  parallel_for(backend, "dacrt_triangle_bounds", count,
               [=] CAUSTICA_HD(size_t i) { bounds[i] = triangle_bounds(tris[i]); });
  out.bounds = backend.reduce_bounds(bounds, count);
  return out;
}

void trace_closest(Backend& backend, const DacrtView& view, const Ray* rays, size_t count,
                   Hit* hits, DacrtTraceStats* stats) {
  if (count == 0) {
    if (stats != nullptr) *stats = {};
    return;
  }
  Buffer<uint64_t> best(backend, count);
  backend.fill_bytes(best.data(), 0xff, count * sizeof(uint64_t));  // kNoHitKey
  divide_and_conquer<Query::kClosest>(backend, view, rays, count, best.data(), nullptr, stats,
                                      nullptr);
  const uint64_t* key = best.data();
  const TriangleVertices* triangles = view.triangles;
  parallel_for(backend, "dacrt_closest_hits", count, [=] CAUSTICA_HD(size_t i) {
    Hit hit;
    const uint64_t k = key[i];
    if (k != kNoHitKey) {
      // The winner's test again, for its barycentrics: the same test on the same inputs.
      const uint32_t tri = uint32_t(k & 0xffffffffu);
      const Ray ray = rays[i];
      float t, u, v;
      if (intersect_triangle(WatertightRay(ray), triangles[tri], ray.t_min, ray.t_max, t, u, v)) {
        hit.t = t;
        hit.u = u;
        hit.v = v;
        hit.triangle = tri;
      }
    }
    hits[i] = hit;
  });
  if (stats != nullptr) stats->peak_scratch_bytes += best.bytes();
}

void trace_any(Backend& backend, const DacrtView& view, const Ray* rays, size_t count,
               uint8_t* blocked, DacrtTraceStats* stats) {
  if (count == 0) {
    if (stats != nullptr) *stats = {};
    return;
  }
  Buffer<uint32_t> words(backend, count);
  words.fill_zero();
  divide_and_conquer<Query::kAny>(backend, view, rays, count, nullptr, words.data(), stats,
                                  nullptr);
  const uint32_t* word = words.data();
  parallel_for(backend, "dacrt_blocked", count,
               [=] CAUSTICA_HD(size_t i) { blocked[i] = word[i] != 0 ? 1 : 0; });
  if (stats != nullptr) stats->peak_scratch_bytes += words.bytes();
}

std::vector<DacrtTerminal> dacrt_terminal_nodes(Backend& backend, const DacrtView& view,
                                                const Ray* rays, size_t count) {
  std::vector<DacrtTerminal> terminals;
  divide_and_conquer<Query::kDivide>(backend, view, rays, count, nullptr, nullptr, nullptr,
                                     &terminals);
  return terminals;
}

}  // namespace caustica
