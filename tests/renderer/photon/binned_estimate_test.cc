// The estimate by counting (binned_estimate.h) against brute force and against the heap search's.

#include "renderer/photon/binned_estimate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "tests/renderer/photon/reference_estimate.h"

namespace caustica {
namespace {

PhotonMap map_of(Backend& backend, const std::vector<Photon>& photons) {
  Buffer<Photon> buf(backend, photons.size());
  buf.upload(photons);
  return build_photon_map(backend, buf);
}

void expect_same(const RadianceEstimate& got, const RadianceEstimate& expected, float unweighted,
                 int query) {
  ASSERT_EQ(got.radius_squared, expected.radius_squared) << "query " << query;
  for (int c = 0; c < 3; ++c) {
    ASSERT_NEAR(got.radiance[c], expected.radiance[c],
                2e-5f * std::max(1.0f, std::abs(expected.radiance[c])) + 1e-6f * unweighted)
        << "query " << query << " channel " << c;
  }
}

// Photons of distinct powers and directions in a slab, queries at every k from 1 to the largest,
// the three kernels, radii that hold fewer than k photons, bounds that are right, too small or
// zero.
TEST(BinnedEstimate, MatchesBruteForce) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  const PhotonMap map = map_of(*backend, photons_in_slab(20000, 23));
  const std::vector<Photon> stored = map.download();  // directions as decoded
  std::mt19937 rng(24);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g;
  std::vector<uint32_t> words(kBinnedWords);
  int bounded = 0;
  for (int q = 0; q < 800; ++q) {
    const Vec3f x(u(rng), u(rng), 0.1f);
    const Vec3f normal = normalize(Vec3f(g(rng), g(rng), 2.0f));
    const uint32_t k = std::vector<uint32_t>{1, 2, 7, 16, 64, 65, 200, 1024}[q % 8];
    const float max_radius = q % 3 == 0 ? 0.03f : 0.5f;
    const DensityKernel kernel = DensityKernel(q % 3);
    const ReferenceEstimate expected =
        reference_estimate(stored, x, normal, Vec3f(0.5f), k, max_radius, kernel);
    float bound = INFINITY;
    if (q % 4 == 1) bound = expected.estimate.radius_squared * 1.3f;  // holds the k nearest
    if (q % 4 == 2) bound = expected.estimate.radius_squared * 0.5f;  // too small: search again
    if (q % 16 == 3) bound = 0.0f;
    bounded += bound < max_radius * max_radius;
    const RadianceEstimate got = estimate_radiance_binned(
        map.view(), x, normal, Vec3f(0.5f), k, max_radius, kernel, words.data(), bound, {});
    expect_same(got, expected.estimate, expected.unweighted, q);
  }
  EXPECT_GT(bounded, 300);
}

// Many photons at one distance from the query, more than the collecting walk keeps: the counting
// refines its bins down to single float values, and then takes as many of them as make k.
TEST(BinnedEstimate, RefinesCrowdedCutsAndTakesExactlyKAtTies) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  // Points stacked 25 deep (ties at every distance), and a dense cloud near (0.5, 0.5) whose
  // distances crowd one bin of eight per octave.
  std::vector<Photon> photons = stacked_photons(400, 25, rng);
  for (int i = 0; i < 4000; ++i) {
    const float angle = 6.2831853f * u(rng), r = 0.1f + 0.001f * u(rng);
    photons.push_back({Vec3f(0.5f + r * std::cos(angle), 0.5f + r * std::sin(angle), 0.0f),
                       Vec3f(1.0f), Vec3f(0, 0, 1)});
  }
  const PhotonMap map = map_of(*backend, photons);
  const std::vector<Photon> stored = map.download();
  std::vector<uint32_t> words(kBinnedWords);
  for (int q = 0; q < 300; ++q) {
    const Vec3f x = q % 2 ? Vec3f(u(rng), u(rng), 0.0f) : Vec3f(0.5f, 0.5f, 0.0f);
    const uint32_t k = std::vector<uint32_t>{10, 33, 64, 500}[q % 4];
    const RadianceEstimate got =
        estimate_radiance_binned(map.view(), x, Vec3f(0, 0, 1), Vec3f(1.0f), k, 1.0f,
                                 DensityKernel::kUniform, words.data(), INFINITY, {});
    const ReferenceEstimate expected = reference_estimate(stored, x, Vec3f(0, 0, 1), Vec3f(1.0f), k,
                                                          1.0f, DensityKernel::kUniform);
    ASSERT_EQ(got.radius_squared, expected.estimate.radius_squared) << "query " << q;
    // Uniform kernel, unit powers: the sum is the number of photons taken.
    const double taken = got.radiance.x * kPi * kPi * got.radius_squared;
    ASSERT_NEAR(taken, double(k), 1e-3 * k) << "query " << q;
  }
}

// The heap search and the counting agree on the renderer's kind of data: photons on the faces of
// a box, with a carried bound from the previous query of a walk.
TEST(BinnedEstimate, AgreesWithTheHeapSearch) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Photon> photons(100000);
  for (auto& ph : photons) {
    Vec3f at(u(rng), u(rng), u(rng));
    at[int(u(rng) * 3) % 3] = u(rng) < 0.5f ? 0.0f : 1.0f;
    ph = {at, Vec3f(u(rng), u(rng), u(rng)), normalize(Vec3f(u(rng), u(rng), u(rng)))};
  }
  const PhotonMap map = map_of(*backend, photons);
  std::vector<uint32_t> words(kBinnedWords);
  std::vector<NeighbourPair> heap(NeighbourHeap<NeighbourPair*>::pairs_for(kMaxNearest));
  Vec3f previous(0.5f, 0.5f, 0.0f);
  float previous_r2 = INFINITY;
  for (int q = 0; q < 2000; ++q) {
    const Vec3f x(std::clamp(previous.x + 0.01f * (u(rng) - 0.5f), 0.0f, 1.0f),
                  std::clamp(previous.y + 0.01f * (u(rng) - 0.5f), 0.0f, 1.0f), 0.0f);
    const uint32_t k = std::vector<uint32_t>{8, 64, 128}[q % 3];
    const DensityKernel kernel = DensityKernel(q % 3);
    const float bound = carried_radius_squared(previous_r2, previous, x);
    const RadianceEstimate by_heap = estimate_radiance_within(
        map.view(), x, Vec3f(0, 0, 1), Vec3f(1.0f), k, 0.2f, kernel, heap.data(), bound, {});
    const RadianceEstimate by_count = estimate_radiance_binned(
        map.view(), x, Vec3f(0, 0, 1), Vec3f(1.0f), k, 0.2f, kernel, words.data(), bound, {});
    expect_same(by_count, by_heap, by_heap.radiance.x + by_heap.radiance.y + by_heap.radiance.z, q);
    previous = x;
    previous_r2 = by_count.radius_squared;
  }
}

}  // namespace
}  // namespace caustica
