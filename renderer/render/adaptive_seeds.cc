#include "renderer/render/adaptive_seeds.h"

#include <algorithm>
#include <vector>

#include "renderer/base/rng.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

// A quadtree node's moments: its requests' positions (in units of the radius, from the centre),
// their squared lengths, their normals, and their number.
struct SeedNode {
  Vec3f position;
  float squared;
  Vec3f normal;
  uint32_t count;
};

// Nodes above level l: (4^l - 1) / 3, so level l starts there and its node j is at offset + j.
CAUSTICA_HDI size_t level_offset(uint32_t level) { return ((size_t(1) << (2 * level)) - 1) / 3; }

// The 2D Morton code of (x, y): x's bits at even positions.
CAUSTICA_HDI uint32_t morton2(uint32_t x, uint32_t y) {
  auto spread = [](uint32_t v) {
    v &= 0xffffu;
    v = (v | (v << 8)) & 0x00ff00ffu;
    v = (v | (v << 4)) & 0x0f0f0f0fu;
    v = (v | (v << 2)) & 0x33333333u;
    v = (v | (v << 1)) & 0x55555555u;
    return v;
  };
  return spread(x) | (spread(y) << 1);
}

// The node's variation: alpha^2 sum |x_i - mean|^2 + sum (2 - 2 n_i . n_mean).
CAUSTICA_HDI float variation(const SeedNode& n, float alpha2) {
  if (n.count == 0) return 0.0f;
  const float spread = n.squared - length_squared(n.position) / float(n.count);
  const float bend = 2.0f * (float(n.count) - length(n.normal));
  return alpha2 * (spread > 0.0f ? spread : 0.0f) + (bend > 0.0f ? bend : 0.0f);
}

}  // namespace

Buffer<GatherSeed> adaptive_seeds(Backend& backend, const GatherRequests& requests,
                                  const SeedingSettings& settings) {
  const uint32_t n = requests.count;
  Buffer<GatherSeed> out(backend, 0);
  if (n == 0 || settings.count == 0 || settings.width == 0 || settings.height == 0) return out;

  // Levels: enough for the larger side, at most kMaxSeedLevels; `shift` folds pixels into leaves.
  uint32_t side_levels = 0;
  while ((1u << side_levels) < std::max(settings.width, settings.height)) ++side_levels;
  const uint32_t levels = std::min(side_levels, kMaxSeedLevels);
  const uint32_t shift = side_levels - levels;
  const size_t leaves = size_t(1) << (2 * levels);
  const size_t leaf_offset = level_offset(levels);

  // Step 1: the requests in leaf order.
  Buffer<uint32_t> codes(backend, n), ids(backend, n);
  uint32_t* code = codes.data();
  uint32_t* id = ids.data();
  const GatherRequest* request = requests.requests;
  const uint32_t width = settings.width;
  parallel_for(backend, "seed_codes", n, [=] CAUSTICA_HD(size_t i) {
    const uint32_t pixel = request[i].pixel;
    code[i] = morton2((pixel % width) >> shift, (pixel / width) >> shift);
    id[i] = uint32_t(i);
  });
  backend.sort_pairs(code, id, n, int(2 * levels));

  // Step 2: each leaf's moments, summed along its run by the run's first request.
  Buffer<SeedNode> node_buffer(backend, level_offset(levels + 1));
  Buffer<uint32_t> run_starts(backend, leaves);
  SeedNode* nodes = node_buffer.data();
  uint32_t* run_start = run_starts.data();
  backend.fill_bytes(nodes, 0, node_buffer.bytes());
  const Vec3f center = settings.center;
  const float inv_radius = settings.radius > 0.0f ? 1.0f / settings.radius : 1.0f;
  parallel_for(backend, "seed_leaves", n, [=] CAUSTICA_HD(size_t i) {
    if (i > 0 && code[i - 1] == code[i]) return;
    SeedNode leaf{Vec3f(0.0f), 0.0f, Vec3f(0.0f), 0u};
    for (size_t j = i; j < n && code[j] == code[i]; ++j) {
      const GatherRequest& q = request[id[j]];
      const Vec3f p = (q.position - center) * inv_radius;
      leaf.position += p;
      leaf.squared += length_squared(p);
      leaf.normal += q.normal;
      ++leaf.count;
    }
    nodes[leaf_offset + code[i]] = leaf;
    run_start[code[i]] = uint32_t(i);
  });

  // Step 3: up the tree, a level at a time.
  for (uint32_t level = levels; level-- > 0;) {
    const size_t offset = level_offset(level), child_offset = level_offset(level + 1);
    parallel_for(backend, "seed_moments_up", size_t(1) << (2 * level), [=] CAUSTICA_HD(size_t j) {
      SeedNode sum{Vec3f(0.0f), 0.0f, Vec3f(0.0f), 0u};
      for (size_t c = 0; c < 4; ++c) {
        const SeedNode& child = nodes[child_offset + 4 * j + c];
        sum.position += child.position;
        sum.squared += child.squared;
        sum.normal += child.normal;
        sum.count += child.count;
      }
      nodes[offset + j] = sum;
    });
  }

  // Step 4: the budget down the tree. Each node's seeds split among its children by weights half
  // variation, half requests, rounded systematically (one jitter a node) so that they add up, and
  // no node gets more seeds than requests: the root's budget is at most the requests, so none is
  // lost and no request is picked twice.
  Buffer<uint32_t> seed_counts(backend, level_offset(levels + 1));
  uint32_t* seeds = seed_counts.data();
  backend.fill_bytes(seeds, 0, seed_counts.bytes());
  const uint32_t budget = std::min(settings.count, n);
  // Written by a launch, ordered after the fill; a copy from the host is not.
  parallel_for(backend, "seed_budget", 1, [=] CAUSTICA_HD(size_t) { *seeds = budget; });
  const float alpha2 = settings.alpha * settings.alpha;
  const uint32_t rng_seed = settings.seed, pass = settings.pass;
  for (uint32_t level = 0; level < levels; ++level) {
    const size_t offset = level_offset(level), child_offset = level_offset(level + 1);
    parallel_for(backend, "seed_budget_down", size_t(1) << (2 * level), [=] CAUSTICA_HD(size_t j) {
      const uint32_t s = seeds[offset + j];
      if (s == 0) return;
      float weight[4], varied = 0.0f, counted = 0.0f;
      for (int c = 0; c < 4; ++c) {
        const SeedNode& child = nodes[child_offset + 4 * j + c];
        weight[c] = variation(child, alpha2);
        varied += weight[c];
        counted += float(child.count);
      }
      for (int c = 0; c < 4; ++c) {
        const float share = float(nodes[child_offset + 4 * j + c].count) / counted;
        weight[c] = varied > 0.0f ? 0.5f * weight[c] / varied + 0.5f * share : share;
      }
      const float jitter = unit_float(stream_key(rng_seed, uint32_t(offset + j), pass));
      float cumulative = 0.0f;
      uint32_t given = 0, share[4], excess = 0;
      for (int c = 0; c < 4; ++c) {
        cumulative += weight[c];
        const uint32_t upto = c == 3 ? s : min_u32(s, uint32_t(float(s) * cumulative + jitter));
        // No child gets more seeds than it has requests; what it cannot take goes to the others.
        const uint32_t count = nodes[child_offset + 4 * j + c].count;
        share[c] = min_u32(upto - given, count);
        excess += upto - given - share[c];
        given = upto;
      }
      for (int c = 0; c < 4; ++c) {
        const uint32_t room = nodes[child_offset + 4 * j + c].count - share[c];
        const uint32_t more = min_u32(room, excess);
        seeds[child_offset + 4 * j + c] = share[c] + more;
        excess -= more;
      }
    });
  }

  // Step 5: each leaf's seeds among its requests, at jittered strides.
  Buffer<uint32_t> slots(backend, leaves);
  const uint32_t total = backend.exclusive_scan(seeds + leaf_offset, slots.data(), leaves);
  out.resize_discard(total);
  GatherSeed* seed_out = out.data();
  const uint32_t* slot = slots.data();
  parallel_for(backend, "seed_pick", leaves, [=] CAUSTICA_HD(size_t j) {
    const uint32_t s = seeds[leaf_offset + j];
    if (s == 0) return;
    const uint32_t count = nodes[leaf_offset + j].count;
    const float jitter = unit_float(stream_key(rng_seed ^ 0x5eedu, uint32_t(j), pass));
    for (uint32_t t = 0; t < s; ++t) {
      const uint32_t k =
          min_u32(count - 1, uint32_t((float(t) + jitter) * float(count) / float(s)));
      const GatherRequest& q = request[id[run_start[j] + k]];
      seed_out[slot[j] + t] = {q.position, q.normal};
    }
  });
  return out;
}

}  // namespace caustica
