// The render pass's gather requests: however little room a pass starts with, it grows it and
// produces the same image bit for bit. The ray queues (batches of closest and any hits, which
// structures that answer batches only need) give the per-thread walks' photons and image bit for
// bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "renderer/estimator/knn_gather.h"
#include "renderer/photon/photon_map.h"
#include "renderer/photon/photon_tracer.h"
#include "renderer/render/whitted.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

std::vector<float> render_with_room(uint32_t requests_per_pixel,
                                    uint32_t photons_per_leaf = kDefaultPhotonsPerLeaf,
                                    bool ray_queues = false,
                                    const std::string& scene_name = "cornell-caustics") {
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/" + scene_name + "/scene.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  if (!scene.ok()) return {};
  scene->camera.width = 64;
  scene->camera.height = 48;
  auto backend = make_cpu_backend(size_t(1) << 30);
  ResidentScene resident = ResidentScene::upload(*backend, *scene);
  PhotonTraceSettings photons{20000, 8, 3, 0};
  photons.ray_queues = ray_queues;
  TracedPhotons traced = trace_photons(*backend, resident, photons);
  PhotonMap caustic = build_photon_map(*backend, traced.caustic, photons_per_leaf);
  PhotonMap global = build_photon_map(*backend, traced.global, photons_per_leaf);
  Film film(*backend, scene->camera.width, scene->camera.height);
  ShadingSettings settings;
  settings.k_nearest = 16;
  settings.max_radius = 30.0f;
  settings.gather_requests_per_pixel = requests_per_pixel;
  settings.ray_queues = ray_queues;
  for (uint32_t pass = 0; pass < 2; ++pass) {
    settings.pass = pass;
    render_pass(*backend, resident, PinholeCamera::from(scene->camera), settings,
                KnnGather(caustic, global), film);
  }
  const std::span<const float> image = film.resolve_linear();
  return {image.begin(), image.end()};
}

TEST(RenderPass, TooLittleRoomForGatherRequestsChangesNothing) {
  std::vector<float> roomy = render_with_room(4);
  std::vector<float> none = render_with_room(0);
  std::vector<float> one = render_with_room(1);  // the glass sphere's pixels need several
  ASSERT_FALSE(roomy.empty());
  ASSERT_EQ(roomy.size(), none.size());
  ASSERT_EQ(roomy.size(), one.size());
  EXPECT_EQ(0, std::memcmp(roomy.data(), none.data(), roomy.size() * sizeof(float)));
  EXPECT_EQ(0, std::memcmp(roomy.data(), one.data(), roomy.size() * sizeof(float)));
  double sum = 0;
  for (float v : roomy) sum += v;
  EXPECT_GT(sum, 64 * 48);  // more than the alpha channel: the image is not black
}

// Every bundled scene (glass trees, mirrors, area and point lights) through the queues and through
// the per-thread walks.
TEST(RenderPass, RayQueuesGiveTheSameImage) {
  for (const char* name : {"cornell-caustics", "cornell-box", "ring"}) {
    SCOPED_TRACE(name);
    const std::vector<float> walked = render_with_room(4, kDefaultPhotonsPerLeaf, false, name);
    const std::vector<float> queued = render_with_room(4, kDefaultPhotonsPerLeaf, true, name);
    ASSERT_FALSE(walked.empty());
    ASSERT_EQ(walked.size(), queued.size());
    EXPECT_EQ(0, std::memcmp(walked.data(), queued.data(), walked.size() * sizeof(float)));
  }
}

TEST(PhotonTrace, RayQueuesGiveTheSamePhotons) {
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/cornell-caustics/scene.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  auto backend = make_cpu_backend(size_t(1) << 30);
  ResidentScene resident = ResidentScene::upload(*backend, *scene);
  PhotonTraceSettings settings{30000, 8, 5, 1};
  const TracedPhotons walked = trace_photons(*backend, resident, settings);
  settings.ray_queues = true;
  const TracedPhotons queued = trace_photons(*backend, resident, settings);
  for (auto [a, b] :
       {std::pair{&walked.caustic, &queued.caustic}, std::pair{&walked.global, &queued.global}}) {
    const std::vector<Photon> x = a->download(), y = b->download();
    ASSERT_GT(x.size(), 100u);
    ASSERT_EQ(x.size(), y.size());
    EXPECT_EQ(0, std::memcmp(x.data(), y.data(), x.size() * sizeof(Photon)));
  }
}

// The photon maps' leaf size (photons_per_leaf_for picks 16 for a GPU's counting gathers) changes
// the order in which a search meets photons, never which k it finds: the images agree but for the
// order of each estimate's sum.
TEST(RenderPass, PhotonMapLeafSizeChangesNothingButSumOrder) {
  const std::vector<float> eight = render_with_room(4, 8);
  ASSERT_FALSE(eight.empty());
  for (uint32_t leaf : {1u, 16u}) {
    const std::vector<float> other = render_with_room(4, leaf);
    ASSERT_EQ(other.size(), eight.size());
    for (size_t i = 0; i < eight.size(); ++i)
      ASSERT_NEAR(other[i], eight[i], 1e-5f * std::max(1.0f, eight[i]))
          << "leaf " << leaf << " value " << i;
  }
}

}  // namespace
}  // namespace caustica
