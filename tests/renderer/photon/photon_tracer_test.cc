// The photon tracer's caps and its counts of the paths they ended: inside a closed sphere with a
// point light at its centre every path hits the sphere at every bounce and survives Russian
// roulette with probability rho each time, so the cap of B bounces (diffuse walls) or of S mirror
// bounces in a row (mirror walls) ends a path with probability rho^B or rho^S, and every path when
// rho is 1.
#include "renderer/photon/photon_tracer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "renderer/photon/photon_shares.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

Scene closed_sphere(float rho, const char* wall = "diffuse") {
  const char* reflects = std::string(wall) == "mirror" ? "reflectance" : "albedo";
  absl::StatusOr<Scene> scene = parse_scene(absl::StrFormat(R"({
      "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "up": [0, 1, 0], "fov": 90,
                 "width": 8, "height": 8},
      "materials": {"wall": {"type": "%s", "%s": [%f, %f, %f]}},
      "lights": [{"type": "point", "position": [0, 0, 0], "intensity": [1, 1, 1]}],
      "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "rings": 16,
                  "segments": 32, "material": "wall"}]
    })",
                                                            wall, reflects, rho, rho, rho),
                                            ".", "closed-sphere.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  return scene.ok() ? *scene : Scene{};
}

TEST(PhotonTracer, TheCapEndsThePathsRouletteSpares) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  constexpr uint32_t kPaths = 100000, kCap = 4;
  for (float rho : {0.5f, 0.8f}) {
    SCOPED_TRACE(absl::StrFormat("albedo %g", rho));
    ResidentScene resident = ResidentScene::upload(*backend, closed_sphere(rho));
    const TracedPhotons traced = trace_photons(*backend, resident, {kPaths, kCap, 3, 0});
    const double p = std::pow(double(rho), kCap);
    const double expected = kPaths * p, sigma = std::sqrt(kPaths * p * (1 - p));
    EXPECT_NEAR(double(traced.capped_paths), expected, 5 * sigma);
  }
}

TEST(PhotonTracer, EveryPathIsCappedWhereNothingAbsorbs) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  ResidentScene resident = ResidentScene::upload(*backend, closed_sphere(1.0f));
  for (uint32_t cap : {2u, 9u}) {
    const TracedPhotons traced = trace_photons(*backend, resident, {5000, cap, 3, 0});
    EXPECT_EQ(traced.capped_paths, 5000u) << "cap " << cap;
  }
}

TEST(PhotonTracer, SharesCountTheWholePassCappedPaths) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  ResidentScene resident = ResidentScene::upload(*backend, closed_sphere(0.7f));
  const TracedPhotons whole = trace_photons(*backend, resident, {20000, 3, 5, 1});
  ASSERT_GT(whole.capped_paths, 0u);
  std::vector<TracedPhotons> shares;
  for (uint32_t first : {0u, 6000u}) {
    PhotonTraceSettings share{first == 0 ? 6000u : 14000u, 3, 5, 1};
    share.first_path = first;
    share.total_paths = 20000;
    shares.push_back(trace_photons(*backend, resident, share));
  }
  EXPECT_EQ(merge_traced_photons(*backend, shares).capped_paths, whole.capped_paths);
}

TEST(PhotonTracer, TheSpecularCapEndsTheMirrorRunsRouletteSpares) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  constexpr uint32_t kPaths = 100000, kRun = 3;
  for (float rho : {0.5f, 0.8f}) {
    SCOPED_TRACE(absl::StrFormat("reflectance %g", rho));
    ResidentScene resident = ResidentScene::upload(*backend, closed_sphere(rho, "mirror"));
    PhotonTraceSettings trace{kPaths, 64, 3, 0};
    trace.max_specular_bounces = kRun;
    const TracedPhotons traced = trace_photons(*backend, resident, trace);
    const double p = std::pow(double(rho), kRun);
    const double expected = kPaths * p, sigma = std::sqrt(kPaths * p * (1 - p));
    EXPECT_NEAR(double(traced.specular_capped_paths), expected, 5 * sigma);
    EXPECT_EQ(traced.capped_paths, 0u);
  }
  ResidentScene lossless = ResidentScene::upload(*backend, closed_sphere(1.0f, "mirror"));
  PhotonTraceSettings trace{5000, 64, 3, 0};
  trace.max_specular_bounces = 7;
  EXPECT_EQ(trace_photons(*backend, lossless, trace).specular_capped_paths, 5000u);
  trace.max_specular_bounces = 64;  // the total cap comes first
  const TracedPhotons by_total = trace_photons(*backend, lossless, trace);
  EXPECT_EQ(by_total.capped_paths, 5000u);
  EXPECT_EQ(by_total.specular_capped_paths, 0u);
}

// With walls that absorb nothing and a cap of B bounces, every path stores a photon at each of
// bounces 1 to B - 1: the first seven in its slots, the rest in the overflow list. The photons
// come as every path's slot photons in path order, then every path's later ones, so that path p's
// bounces are global[7p, 7p + 7) and then the B - 8 from 7 paths + (B - 8) p on; each photon
// arrives from the one before it on its path, which no other order of the photons would give.
TEST(PhotonTracer, EachPathsPhotonsComeInBounceOrderSlotsFirst) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  ResidentScene resident = ResidentScene::upload(*backend, closed_sphere(1.0f));
  constexpr uint32_t kPaths = 3000, kCap = 20, kSlots = 7, kLater = kCap - 1 - kSlots;
  const TracedPhotons traced = trace_photons(*backend, resident, {kPaths, kCap, 3, 0});
  ASSERT_EQ(traced.caustic.size(), 0u);
  ASSERT_EQ(traced.global.size(), size_t(kPaths) * (kCap - 1));
  ASSERT_EQ(traced.global_from_slots, size_t(kPaths) * kSlots);
  const std::vector<Photon> photons = traced.global.download();
  size_t chained = 0;
  for (uint32_t path = 0; path < kPaths; ++path) {
    std::vector<Photon> on_path(photons.begin() + path * kSlots,
                                photons.begin() + (path + 1) * kSlots);
    const auto later = photons.begin() + kPaths * kSlots + path * kLater;
    on_path.insert(on_path.end(), later, later + kLater);
    for (size_t b = 1; b < on_path.size(); ++b) {
      const Vec3f travel = normalize(on_path[b].position - on_path[b - 1].position);
      ASSERT_GT(dot(travel, -on_path[b].incoming), 0.99f) << "path " << path << " bounce " << b;
      ++chained;
    }
  }
  EXPECT_EQ(chained, size_t(kPaths) * (kCap - 2));
}

std::vector<Photon> all_photons(const TracedPhotons& traced) {
  std::vector<Photon> all = traced.caustic.download();
  for (const Photon& p : traced.global.download()) all.push_back(p);
  return all;
}

bool same_photons(const std::vector<Photon>& a, const std::vector<Photon>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](auto& x, auto& y) {
           return x.position == y.position && x.power == y.power && x.incoming == y.incoming;
         });
}

Scene bundled_scene(const std::string& name) {
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/" + name + "/scene.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  return scene.ok() ? *scene : Scene{};
}

// The cap is checked before a mirror or glass bounce draws a sample: where no path takes one, a
// cap of none changes no photon, and where glass makes the caustics, they need its two crossings.
TEST(PhotonTracer, TheSpecularCapChangesOnlyThePathsItEnds) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  ResidentScene diffuse = ResidentScene::upload(*backend, bundled_scene("cornell-box"));
  PhotonTraceSettings trace{20000, 64, 5, 0};
  const std::vector<Photon> uncapped = all_photons(trace_photons(*backend, diffuse, trace));
  ASSERT_GT(uncapped.size(), 0u);
  trace.max_specular_bounces = 0;
  const TracedPhotons capped = trace_photons(*backend, diffuse, trace);
  EXPECT_TRUE(same_photons(all_photons(capped), uncapped));
  EXPECT_EQ(capped.specular_capped_paths, 0u);

  ResidentScene caustics = ResidentScene::upload(*backend, bundled_scene("cornell-caustics"));
  trace.max_specular_bounces = 0;
  const TracedPhotons none = trace_photons(*backend, caustics, trace);
  EXPECT_EQ(none.caustic.size(), 0u);
  EXPECT_GT(none.specular_capped_paths, 0u);
  trace.max_specular_bounces = 2;  // into the glass sphere and out
  const TracedPhotons through = trace_photons(*backend, caustics, trace);
  EXPECT_GT(through.caustic.size(), 0u);
  trace.max_specular_bounces = 64;
  const TracedPhotons all = trace_photons(*backend, caustics, trace);
  EXPECT_GT(all.caustic.size(), through.caustic.size());
  EXPECT_LT(through.specular_capped_paths, none.specular_capped_paths);
}

}  // namespace
}  // namespace caustica
