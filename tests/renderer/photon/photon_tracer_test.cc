// The photon tracer's count of paths that max_bounces ended: inside a closed diffuse sphere with
// a point light at its centre every path hits the sphere at every bounce and survives Russian
// roulette with probability rho each time, so the cap of B bounces ends a path with probability
// rho^B, and every path when rho is 1.
#include "renderer/photon/photon_tracer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "absl/strings/str_format.h"
#include "renderer/photon/photon_shares.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

Scene closed_sphere(float rho) {
  absl::StatusOr<Scene> scene = parse_scene(absl::StrFormat(R"({
      "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "up": [0, 1, 0], "fov": 90,
                 "width": 8, "height": 8},
      "materials": {"wall": {"type": "diffuse", "albedo": [%f, %f, %f]}},
      "lights": [{"type": "point", "position": [0, 0, 0], "intensity": [1, 1, 1]}],
      "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "rings": 16,
                  "segments": 32, "material": "wall"}]
    })",
                                                            rho, rho, rho),
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

}  // namespace
}  // namespace caustica
