// Photon map kNN against brute force, and the kernels' normalisation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "renderer/photon/knn_estimate.h"
#include "tests/renderer/photon/reference_estimate.h"

namespace caustica {
namespace {

struct Points {
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(1) << 30);
  PhotonMap map;
  std::vector<Photon> photons;
};

std::unique_ptr<Points> make_map(size_t n, uint32_t seed, bool clustered,
                                 uint32_t photons_per_leaf = kDefaultPhotonsPerLeaf,
                                 PhotonMapNodes nodes = kDefaultPhotonMapNodes) {
  auto p = std::make_unique<Points>();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  p->photons.resize(n);
  for (size_t i = 0; i < n; ++i) {
    Vec3f pos(u(rng), u(rng), clustered ? 0.0f : u(rng));         // clustered: all on a plane
    if (clustered && i % 10 == 0) pos = Vec3f(0.5f, 0.5f, 0.0f);  // many coincident points
    p->photons[i] = {pos, Vec3f(float(i), 1, 1), Vec3f(0, 0, 1)};
  }
  Buffer<Photon> buf(*p->backend, n);
  buf.upload(p->photons);
  p->map = build_photon_map(*p->backend, buf, photons_per_leaf, nodes);
  return p;
}

void check_knn(size_t n, bool clustered, uint32_t photons_per_leaf = kDefaultPhotonsPerLeaf,
               PhotonMapNodes nodes = kDefaultPhotonMapNodes) {
  auto p = make_map(n, 5, clustered, photons_per_leaf, nodes);
  ASSERT_EQ(p->map.view().node_layout, nodes);
  auto sorted = p->map.download();
  ASSERT_EQ(sorted.size(), n);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-0.1f, 1.1f);
  std::vector<NeighbourPair> storage(NeighbourHeap<NeighbourPair*>::pairs_for(kMaxNearest));
  NeighbourHeap<NeighbourPair*> heap{storage.data()};
  for (int q = 0; q < 2000; ++q) {
    Vec3f x(u(rng), u(rng), clustered ? 0.01f * u(rng) : u(rng));
    // Every k modulo 4: the heap's last group of four children is whole only for k = 4n + 1,
    // and otherwise ends in sentinels.
    uint32_t k = std::vector<uint32_t>{1, 2, 3, 4, 5, 6, 7, 64, 201}[q % 9];
    float max_r = q % 3 == 0 ? 0.05f : 10.0f;
    uint32_t found = find_nearest(p->map.view(), x, k, max_r * max_r, heap);

    std::vector<float> d2(n);
    for (size_t i = 0; i < n; ++i) d2[i] = length_squared(sorted[i].position - x);
    std::vector<float> within;
    for (float d : d2)
      if (d < max_r * max_r) within.push_back(d);
    std::sort(within.begin(), within.end());
    size_t expected = std::min<size_t>(k, within.size());
    ASSERT_EQ(found, expected) << "query " << q;
    std::vector<float> got(found);
    for (uint32_t i = 0; i < found; ++i) {
      got[i] = heap[i].distance_squared;
      ASSERT_EQ(got[i], d2[heap[i].index]);  // distance matches the photon it names
    }
    std::sort(got.begin(), got.end());
    for (size_t i = 0; i < expected; ++i)
      ASSERT_EQ(got[i], within[i]) << "query " << q << " #" << i;
  }
}

TEST(PhotonMapKnn, MatchesBruteForceUniform) { check_knn(20000, false); }
TEST(PhotonMapKnn, MatchesBruteForceOnPlaneWithCoincidentPoints) { check_knn(20000, true); }
TEST(PhotonMapKnn, SmallMaps) {
  for (size_t n : {1, 2, 3, 17}) check_knn(n, false);
}
// Leaves of one photon, of a size that leaves a partial last leaf, and larger than the map.
TEST(PhotonMapKnn, AnyLeafSize) {
  for (uint32_t per_leaf : {1u, 3u, 32u}) check_knn(3001, false, per_leaf);
  check_knn(5, false, 16);
}

// The same searches over the compact node layout.
TEST(PhotonMapKnn, SiblingPairNodesMatchBruteForce) {
  const PhotonMapNodes pairs = PhotonMapNodes::kSiblingPairs;
  check_knn(20000, false, kDefaultPhotonsPerLeaf, pairs);
  check_knn(20000, true, kDefaultPhotonsPerLeaf, pairs);
  for (size_t n : {1, 2, 3, 17}) check_knn(n, false, kDefaultPhotonsPerLeaf, pairs);
  for (uint32_t per_leaf : {1u, 3u, 32u}) check_knn(3001, false, per_leaf, pairs);
}

// Both layouts give a search the same boxes, so it visits the same leaves in the same order and
// leaves the same heap, entry for entry; the compact map's nodes take half the bytes.
TEST(PhotonMapKnn, BothNodeLayoutsFindTheSameNeighboursInTheSameOrder) {
  for (bool clustered : {false, true}) {
    auto boxes = make_map(30000, 8, clustered, 8, PhotonMapNodes::kBoxPairs);
    auto pairs = make_map(30000, 8, clustered, 8, PhotonMapNodes::kSiblingPairs);
    EXPECT_EQ(pairs->map.pair_nodes.size(), boxes->map.bvh.nodes.size());
    EXPECT_EQ(pairs->map.bvh.nodes.size(), 0u);
    EXPECT_EQ(2 * pairs->map.pair_nodes.bytes(), boxes->map.bvh.nodes.bytes());
    std::vector<NeighbourPair> a_storage(NeighbourHeap<NeighbourPair*>::pairs_for(kMaxNearest)),
        b_storage(a_storage.size());
    NeighbourHeap<NeighbourPair*> a{a_storage.data()}, b{b_storage.data()};
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-0.1f, 1.1f);
    for (int q = 0; q < 3000; ++q) {
      const Vec3f x(u(rng), u(rng), clustered ? 0.01f * u(rng) : u(rng));
      const uint32_t k = 1 + uint32_t(q % 100);
      const float max_r = q % 2 == 0 ? 0.03f : 10.0f;
      const uint32_t found_a = find_nearest(boxes->map.view(), x, k, max_r * max_r, a);
      const uint32_t found_b = find_nearest(pairs->map.view(), x, k, max_r * max_r, b);
      ASSERT_EQ(found_a, found_b) << "query " << q;
      for (uint32_t i = 0; i < found_a; ++i) {
        ASSERT_EQ(a[i].index, b[i].index) << "query " << q << " #" << i;
        ASSERT_EQ(a[i].distance_squared, b[i].distance_squared) << "query " << q << " #" << i;
      }
    }
  }
}

TEST(PhotonMap, LeavesCoverTheirPhotons) {
  auto p = make_map(10007, 4, false, 8);
  const PhotonMapView v = p->map.view();
  ASSERT_EQ(v.leaf_count, (10007u + 7) / 8);
  ASSERT_EQ(p->map.bvh.nodes.size(), v.leaf_count - 1);
  auto nodes = p->map.bvh.nodes.download();
  auto sorted = p->map.download();
  std::vector<int> leaf_seen(v.leaf_count);
  for (const BvhNode& n : nodes)
    for (int c = 0; c < 2; ++c) {
      if (!is_leaf(n.child[c].index)) continue;
      uint32_t leaf = leaf_index(n.child[c].index);
      ++leaf_seen[leaf];
      for (uint32_t i = v.leaf_begin(leaf); i < v.leaf_end(leaf); ++i) {
        ASSERT_TRUE(n.child[c].bounds().contains(Aabb{sorted[i].position, sorted[i].position}))
            << "leaf " << leaf;
      }
    }
  for (int s : leaf_seen) ASSERT_EQ(s, 1);
}

// The side test on the encoded direction agrees with the decoded unit vector's dot product
// wherever that is not within rounding of zero, and the axes' signs come out exactly.
TEST(PhotonMap, SideTestNeedsNoNormalisation) {
  std::mt19937 rng(19);
  std::normal_distribution<float> g;
  int decided = 0;
  for (int i = 0; i < 200000; ++i) {
    const Vec3f d = normalize(Vec3f(g(rng), g(rng), g(rng)));
    const Vec3f n = normalize(Vec3f(g(rng), g(rng), g(rng)));
    const uint32_t bits = encode_octahedral(d);
    const float along = dot(decode_octahedral(bits), n);
    if (std::abs(along) < 1e-6f) continue;
    ++decided;
    ASSERT_EQ(octahedral_along(bits, n), along > 0.0f) << i;
  }
  EXPECT_GT(decided, 199000);
  for (Vec3f axis : {Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(0, 0, 1)}) {
    EXPECT_TRUE(octahedral_along(encode_octahedral(axis), axis));
    EXPECT_FALSE(octahedral_along(encode_octahedral(-axis), axis));
  }
}

// Incoming directions survive the 32-bit octahedral encoding within 1e-4 radians.
TEST(PhotonMap, StoresDirectionsWithinTenthOfMilliradian) {
  std::mt19937 rng(17);
  std::normal_distribution<float> g;
  double worst = 0;
  std::vector<Vec3f> dirs = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int i = 0; i < 100000; ++i) dirs.push_back(normalize(Vec3f(g(rng), g(rng), g(rng))));
  for (Vec3f d : dirs) {
    Vec3f back = decode_octahedral(encode_octahedral(d));
    // The angle from the cross product, in double: acos of a float dot product near 1 would
    // measure its own rounding.
    double cx = double(back.y) * d.z - double(back.z) * d.y,
           cy = double(back.z) * d.x - double(back.x) * d.z,
           cz = double(back.x) * d.y - double(back.y) * d.x;
    double angle = std::asin(std::min(1.0, std::sqrt(cx * cx + cy * cy + cz * cz)));
    worst = std::max(worst, angle);
    ASSERT_NEAR(length(back), 1.0f, 1e-6f);
  }
  EXPECT_LT(worst, 1e-4);
}

TEST(PhotonMap, KeepsEveryPhotonOnce) {
  auto p = make_map(5000, 3, false);
  auto sorted = p->map.download();
  std::vector<int> seen(5000);
  for (const Photon& ph : sorted) ++seen[size_t(ph.power.x)];
  for (int s : seen) ASSERT_EQ(s, 1);
}

// Two maps built together are the maps built alone, byte for byte: each set keeps its own bounds
// and curve order though the sets share one sort. The sets differ in size, bounds and leaf count.
TEST(PhotonMap, PairBuiltTogetherIsEachBuiltAlone) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Photon> a(3001), b(12345);
  for (size_t i = 0; i < a.size(); ++i)
    a[i] = {Vec3f(u(rng), u(rng), 0.0f), Vec3f(float(i), 1, 1), Vec3f(0, 0, 1)};
  for (size_t i = 0; i < b.size(); ++i)
    b[i] = {Vec3f(4 * u(rng) - 2, u(rng), 3 * u(rng)), Vec3f(1, float(i), 1), Vec3f(0, 1, 0)};
  Buffer<Photon> first(*backend, a.size()), second(*backend, b.size()), none(*backend, 0);
  first.upload(a);
  second.upload(b);
  const auto same = [](const PhotonMap& together, const PhotonMap& alone) {
    const auto bytes = [](const auto& v) {
      using T = typename std::decay_t<decltype(v)>::value_type;
      std::vector<uint8_t> out(v.size() * sizeof(T));
      if (!v.empty()) std::memcpy(out.data(), v.data(), out.size());
      return out;
    };
    EXPECT_EQ(together.bvh.root, alone.bvh.root);
    EXPECT_EQ(together.bvh.leaf_count, alone.bvh.leaf_count);
    EXPECT_EQ(bytes(together.bvh.nodes.download()), bytes(alone.bvh.nodes.download()));
    EXPECT_EQ(bytes(together.positions.download()), bytes(alone.positions.download()));
    EXPECT_EQ(bytes(together.flux.download()), bytes(alone.flux.download()));
  };
  for (uint32_t per_leaf : {1u, 8u, 16u}) {
    SCOPED_TRACE(per_leaf);
    const PhotonMapPair pair = build_photon_maps(*backend, first, second, per_leaf);
    same(pair.first, build_photon_map(*backend, first, per_leaf));
    same(pair.second, build_photon_map(*backend, second, per_leaf));
    const PhotonMapPair one_empty = build_photon_maps(*backend, none, second, per_leaf);
    EXPECT_EQ(one_empty.first.size(), 0u);
    same(one_empty.second, pair.second);
  }
}

// Each kernel, integrated over the unit disk, gives pi (the area), so estimates are unbiased for
// constant density whatever the kernel.
TEST(Kernels, IntegrateToDiskArea) {
  for (DensityKernel k :
       {DensityKernel::kUniform, DensityKernel::kCone, DensityKernel::kEpanechnikov}) {
    double sum = 0;
    const int steps = 200000;
    for (int i = 0; i < steps; ++i) {
      double r = (i + 0.5) / steps;
      sum += kernel_weight(k, float(r * r)) * 2 * kPi * r / steps;
    }
    EXPECT_NEAR(sum, kPi, 1e-3) << int(k);
  }
}

// Photons of equal power spread uniformly on a plane: the estimate recovers the irradiance.
TEST(Density, RecoversUniformIrradiance) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const size_t n = 400000;
  const float total_flux = 4.0f;  // W over a unit square: E = 4 W/m^2
  std::vector<Photon> photons(n);
  for (auto& ph : photons)
    ph = {Vec3f(u(rng), u(rng), 0), Vec3f(total_flux / n), normalize(Vec3f(0.3f, 0, 1))};
  Buffer<Photon> buf(*backend, n);
  buf.upload(photons);
  PhotonMap map = build_photon_map(*backend, buf);
  std::vector<NeighbourPair> heap(NeighbourHeap<NeighbourPair*>::pairs_for(kMaxNearest));
  for (DensityKernel k :
       {DensityKernel::kUniform, DensityKernel::kCone, DensityKernel::kEpanechnikov}) {
    double mean = 0;
    const int queries = 400;
    for (int q = 0; q < queries; ++q) {
      Vec3f x(0.2f + 0.6f * u(rng), 0.2f + 0.6f * u(rng), 0);
      Vec3f l =
          estimate_radiance(map.view(), x, Vec3f(0, 0, 1), Vec3f(1.0f), 256, 1.0f, k, heap.data());
      mean += l.x / queries;
    }
    // L = rho E / pi with rho = 1.
    EXPECT_NEAR(mean, total_flux / kPi, 0.01 * total_flux / kPi) << int(k);
    // Photons arriving from below the surface do not count.
    Vec3f back = estimate_radiance(map.view(), Vec3f(0.5f, 0.5f, 0), Vec3f(0, 0, -1), Vec3f(1.0f),
                                   64, 1.0f, k, heap.data());
    EXPECT_EQ(back.x, 0.0f);
  }
}

// A bound carried from the previous point of a walk (as the renderer's gathers carry it from one
// Morton-neighbour request to the next) finds the same k-th distance and estimate as a search
// from the maximum radius; so does a bound that is too small, by searching again.
TEST(Density, CarriedBoundsChangeNothingButSpeed) {
  auto p = make_map(100000, 3, /*clustered=*/true);
  const PhotonMapView map = p->map.view();
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> step(-0.004f, 0.004f);
  std::vector<NeighbourPair> heap(NeighbourHeap<NeighbourPair*>::pairs_for(kMaxNearest));
  Vec3f x(0.3f, 0.3f, 0.0f), previous = x;
  float previous_r2 = INFINITY;
  int bounded = 0;
  for (int q = 0; q < 3000; ++q) {
    x = Vec3f(std::clamp(x.x + step(rng), 0.0f, 1.0f), std::clamp(x.y + step(rng), 0.0f, 1.0f),
              0.0f);
    const uint32_t k = q % 2 ? 64 : 17;
    const DensityKernel kernel = DensityKernel(q % 3);
    const float max_radius = q % 500 < 5 ? 0.005f : 0.5f;  // a few searches find fewer than k
    const RadianceEstimate lone = estimate_radiance_within(
        map, x, Vec3f(0, 0, 1), Vec3f(1.0f), k, max_radius, kernel, heap.data(), INFINITY, {});
    float bound = q % 2 ? carried_radius_squared(previous_r2, previous, x) : INFINITY;
    if (q % 7 == 0) bound = 0.25f * lone.radius_squared;  // too small: the search must recover
    bounded += bound < max_radius * max_radius;
    const RadianceEstimate carried = estimate_radiance_within(
        map, x, Vec3f(0, 0, 1), Vec3f(1.0f), k, max_radius, kernel, heap.data(), bound, {});
    ASSERT_EQ(carried.radius_squared, lone.radius_squared) << "query " << q;
    for (int c = 0; c < 3; ++c)
      ASSERT_NEAR(carried.radiance[c], lone.radiance[c], 1e-5f * std::max(1.0f, lone.radiance[c]))
          << q;
    previous = x;
    previous_r2 = carried.radius_squared;
  }
  EXPECT_GT(bounded, 1500);
}

// The estimate against brute force (reference_estimate.h).
TEST(Density, EstimateMatchesBruteForce) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  const std::vector<Photon> photons = photons_in_slab(20000, 23);
  Buffer<Photon> buf(*backend, photons.size());
  buf.upload(photons);
  const PhotonMap map = build_photon_map(*backend, buf);
  const std::vector<Photon> stored = map.download();  // directions as decoded
  std::vector<NeighbourPair> heap(NeighbourHeap<NeighbourPair*>::pairs_for(kMaxNearest));
  std::mt19937 rng(24);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g;
  for (int q = 0; q < 600; ++q) {
    const Vec3f x(u(rng), u(rng), 0.1f);
    const Vec3f normal = normalize(Vec3f(g(rng), g(rng), 2.0f));
    const uint32_t k = std::vector<uint32_t>{1, 7, 64, 200}[q % 4];
    const float max_radius = q % 3 == 0 ? 0.03f : 0.5f;
    const DensityKernel kernel = DensityKernel(q % 3);
    const RadianceEstimate got = estimate_radiance_within(
        map.view(), x, normal, Vec3f(0.5f), k, max_radius, kernel, heap.data(), INFINITY, {});
    const RadianceEstimate expected =
        reference_estimate(stored, x, normal, Vec3f(0.5f), k, max_radius, kernel).estimate;
    ASSERT_EQ(got.radius_squared, expected.radius_squared) << "query " << q;
    for (int c = 0; c < 3; ++c) {
      ASSERT_NEAR(got.radiance[c], expected.radiance[c],
                  1e-5 * std::max(1.0f, expected.radiance[c]))
          << "query " << q;
    }
  }
}

// Photons stacked on the same points, so that many lie exactly at the k-th distance: the estimate
// takes as many of them as make k, whichever ones the search kept.
TEST(Density, TakesExactlyKWhenPhotonsTieAtTheKthDistance) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const std::vector<Photon> photons = stacked_photons(400, 25, rng);
  Buffer<Photon> buf(*backend, photons.size());
  buf.upload(photons);
  const PhotonMap map = build_photon_map(*backend, buf);
  std::vector<NeighbourPair> heap(NeighbourHeap<NeighbourPair*>::pairs_for(kMaxNearest));
  for (int q = 0; q < 300; ++q) {
    const Vec3f x(u(rng), u(rng), 0.0f);
    const uint32_t k = std::vector<uint32_t>{10, 33, 64}[q % 3];
    const RadianceEstimate got =
        estimate_radiance_within(map.view(), x, Vec3f(0, 0, 1), Vec3f(1.0f), k, 1.0f,
                                 DensityKernel::kUniform, heap.data(), INFINITY, {});
    // Uniform kernel, unit powers: the sum is the number of photons taken.
    const double taken = got.radiance.x * kPi * kPi * got.radius_squared;
    ASSERT_NEAR(taken, double(k), 1e-3 * k) << "query " << q;
  }
}

}  // namespace
}  // namespace caustica
