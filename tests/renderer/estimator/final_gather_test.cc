// Final gathering (settings.final_gather) against the closed sphere's series, and its adaptive
// seeding (render/adaptive_seeds.h) against what it promises.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "renderer/render/adaptive_seeds.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// Every interreflection comes through the gather rays' photon estimates, interpolated.
TEST(FinalGather, InsideDiffuseSphereMatchesInterreflectionSeries) {
  const InsideDiffuseSphere sphere;
  auto engine = engine_with(sphere.scene(
      R"({"photons": 100000, "k": 64, "final_gather": true, "final_gather_rays": 64,
          "final_gather_seeds": 512})"));
  ASSERT_TRUE(engine->render(4).ok());
  const double mean = InsideDiffuseSphere::mean(engine->image_linear());
  const double error = std::fabs(mean - sphere.expected()) / sphere.expected();
  EXPECT_LT(error, 0.01) << "mean " << mean << " expected " << sphere.expected();
  std::printf("final gathering inside diffuse sphere: relative error %.3f%%\n", 100 * error);
}

TEST(FinalGather, IsForTheKnnEstimator) {
  absl::StatusOr<Scene> scene = parse_scene(
      R"({"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "fov": 40, "width": 8,
                     "height": 8},
          "settings": {"estimator": "sppm", "final_gather": true},
          "shapes": []})",
      ".", "fg.json");
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.status().message(),
            "fg.json: settings.final_gather: is for the knn estimator; sppm gathers its indirect "
            "light itself");
}

// Requests on a 64 x 64 image: a wall facing +z meeting another facing -x along the column x = 43,
// off the quadtree's node boundaries. Every pixel has one request.
constexpr float kCorner = 43.0f / 64.0f;

struct SeedingScene {
  std::vector<GatherRequest> requests;
  SeedingScene() {
    for (uint32_t y = 0; y < 64; ++y) {
      for (uint32_t x = 0; x < 64; ++x) {
        GatherRequest q{};
        q.pixel = y * 64 + x;
        q.weight = Vec3f(1.0f);
        const float u = float(x) / 64.0f, v = float(y) / 64.0f;
        if (x < 43) {
          q.position = Vec3f(u, v, 0.0f);
          q.normal = Vec3f(0, 0, 1);
        } else {
          q.position = Vec3f(kCorner, v, u - kCorner);
          q.normal = Vec3f(-1, 0, 0);
        }
        requests.push_back(q);
      }
    }
  }
};

std::vector<GatherSeed> seeds_of(const std::vector<GatherRequest>& requests, uint32_t count,
                                 uint32_t pass) {
  auto backend = make_cpu_backend(size_t(1) << 28);
  Buffer<GatherRequest> buffer(*backend, 0);
  buffer.upload(requests);
  SeedingSettings s;
  s.width = s.height = 64;
  s.count = count;
  s.pass = pass;
  return adaptive_seeds(*backend, {buffer.data(), nullptr, nullptr, uint32_t(requests.size())}, s)
      .download();
}

TEST(AdaptiveSeeds, GivesTheBudgetAtRequestsAndMoreWhereNormalsBend) {
  const SeedingScene scene;
  const std::vector<GatherSeed> seeds = seeds_of(scene.requests, 256, 0);
  ASSERT_EQ(seeds.size(), 256u);
  int near_edge = 0;
  for (const GatherSeed& g : seeds) {
    // Every seed is one of the requests.
    const bool found = std::any_of(scene.requests.begin(), scene.requests.end(), [&](auto& q) {
      return q.position.x == g.position.x && q.position.y == g.position.y &&
             q.position.z == g.position.z && q.normal.x == g.normal.x && q.normal.z == g.normal.z;
    });
    EXPECT_TRUE(found);
    // The columns 39..46 around the corner: 8 of 64, an eighth of the budget if seeded evenly.
    if (std::fabs(g.position.x - kCorner) < 0.065f && g.position.z < 0.065f) ++near_edge;
  }
  EXPECT_GT(near_edge, 256 / 8 * 3 / 2);
  std::printf("seeds within 4 pixels of the corner: %d of 256 (32 if even)\n", near_edge);
  // Another pass draws other seeds; the same pass the same ones.
  const std::vector<GatherSeed> again = seeds_of(scene.requests, 256, 0);
  const std::vector<GatherSeed> other = seeds_of(scene.requests, 256, 1);
  ASSERT_EQ(again.size(), seeds.size());
  int same = 0, moved = 0;
  for (size_t i = 0; i < seeds.size(); ++i) {
    same +=
        seeds[i].position.x == again[i].position.x && seeds[i].position.y == again[i].position.y;
    moved += i < other.size() && (seeds[i].position.x != other[i].position.x ||
                                  seeds[i].position.y != other[i].position.y);
  }
  EXPECT_EQ(same, int(seeds.size()));
  EXPECT_GT(moved, 0);
}

TEST(AdaptiveSeeds, NoMoreSeedsThanRequests) {
  const SeedingScene scene;
  std::vector<GatherRequest> few(scene.requests.begin(), scene.requests.begin() + 40);
  EXPECT_EQ(seeds_of(few, 256, 0).size(), 40u);
  EXPECT_TRUE(seeds_of({}, 256, 0).empty());
}

}  // namespace
}  // namespace caustica
