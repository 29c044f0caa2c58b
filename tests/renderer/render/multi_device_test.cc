// One engine over several devices (EngineOptions::backends) against one over a single device: each
// device traces a share of every pass's photons, builds the maps from all the shares merged, and
// renders its bands of rows. Here the devices are CPU backends, so the whole path runs without a
// GPU; the GPU suite runs it on CUDA backends. Every estimator whose samples follow from the pixel
// gives the same image bit for bit; final gathering, whose gather rays are numbered per device,
// gives it within the noise.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "renderer/engine.h"
#include "renderer/render/camera.h"
#include "renderer/render/image_error.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

Scene small_scene(const std::string& name, int width, int height,
                  const std::function<void(RenderSettings&)>& tweak = {}) {
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/" + name + "/scene.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  if (!scene.ok()) return {};
  scene->camera.width = width;
  scene->camera.height = height;
  scene->settings.photons_per_pass = 20000;
  if (tweak) tweak(scene->settings);
  return *std::move(scene);
}

std::unique_ptr<Engine> engine_on(size_t devices) {
  EngineOptions options;
  for (size_t i = 0; i < devices; ++i) {
    options.backends.push_back(std::shared_ptr<Backend>(make_cpu_backend(size_t(1) << 30)));
  }
  absl::StatusOr<std::unique_ptr<Engine>> engine = Engine::create(options);
  EXPECT_TRUE(engine.ok()) << engine.status();
  return engine.ok() ? *std::move(engine) : nullptr;
}

std::vector<float> image_of(Engine& engine) {
  const std::span<const float> image = engine.image_linear();
  return {image.begin(), image.end()};
}

// `scene` rendered for `passes` passes on `devices` devices.
std::vector<float> render_on(size_t devices, const Scene& scene, uint32_t passes) {
  std::unique_ptr<Engine> engine = engine_on(devices);
  if (!engine) return {};
  absl::StatusOr<RebuildReport> loaded = engine->load(scene);
  EXPECT_TRUE(loaded.ok()) << loaded.status();
  if (!loaded.ok()) return {};
  absl::StatusOr<PassReport> rendered = engine->render(passes);
  EXPECT_TRUE(rendered.ok()) << rendered.status();
  return rendered.ok() ? image_of(*engine) : std::vector<float>{};
}

// Every value of `image` within `tolerance` of `reference`'s, relative to the larger (0: bit for
// bit).
void expect_same_image(const std::vector<float>& image, const std::vector<float>& reference,
                       const std::string& what, double tolerance = 0) {
  ASSERT_EQ(image.size(), reference.size()) << what;
  ASSERT_FALSE(image.empty()) << what;
  size_t differing = 0;
  double worst = 0;
  for (size_t i = 0; i < image.size(); ++i) {
    if (image[i] == reference[i]) continue;
    const double scale = std::max(std::fabs(double(image[i])), std::fabs(double(reference[i])));
    worst = std::max(worst, std::fabs(double(image[i]) - reference[i]) / scale);
    ++differing;
  }
  if (tolerance == 0) {
    EXPECT_EQ(differing, 0u) << what << ": values that differ from one device's image";
  } else {
    EXPECT_LE(worst, tolerance) << what << ": the largest relative difference, " << differing
                                << " values differing";
  }
  double sum = 0;
  for (float v : reference) sum += v;
  EXPECT_GT(sum, 0.0) << what << ": the image is black, which proves nothing";
}

TEST(RowBands, DealEveryRowToExactlyOneDevice) {
  for (int devices : {1, 2, 3, 5}) {
    for (int height : {1, 31, 32, 64, 65, 100, 1024}) {
      std::vector<int> owner(size_t(height), -1);
      int total = 0;
      for (int d = 0; d < devices; ++d) {
        const RowBands bands{32, devices, d};
        const int rows = bands.film_rows(height);
        total += rows;
        for (int y = 0; y < rows; ++y) {
          const int row = bands.image_row(y);
          ASSERT_GE(row, 0);
          ASSERT_LT(row, height) << devices << " devices, height " << height;
          ASSERT_EQ(owner[size_t(row)], -1) << "row " << row << " dealt twice";
          owner[size_t(row)] = d;
          if (y > 0) EXPECT_GT(row, bands.image_row(y - 1)) << "rows keep the image's order";
        }
      }
      EXPECT_EQ(total, height) << devices << " devices, height " << height;
    }
  }
}

TEST(RowBands, TheCameraNumbersEachPixelAsTheWholeImageDoes) {
  Camera c;
  c.width = 10;
  c.height = 70;
  const PinholeCamera whole = PinholeCamera::from(c);
  const PinholeCamera second = whole.with_bands({32, 2, 1});
  EXPECT_EQ(second.height, 32);  // rows 32..63
  EXPECT_EQ(second.stream(0), 320u);
  EXPECT_EQ(second.stream(10 * 5 + 3), uint32_t(37 * 10 + 3));
  const Ray a = second.ray_through(3.25f, 5.5f), b = whole.ray_through(3.25f, 37.5f);
  EXPECT_EQ(0, std::memcmp(&a, &b, sizeof(Ray)));
}

struct Case {
  const char* name;
  const char* scene;
  std::function<void(RenderSettings&)> tweak;
  // 0: bit for bit. The knn gathers search for a warp's (or a CPU batch's) requests together, in
  // Hilbert order, and which neighbours share a search sets the order in which an estimate sums
  // its photons: with some rows on another device, the last bits of a few estimates move.
  double tolerance = 0;
};

constexpr double kKnnTolerance = 1e-5;

class MultiDeviceTest : public ::testing::TestWithParam<Case> {};

TEST_P(MultiDeviceTest, TwoAndThreeDevicesRenderOneDevicesImage) {
  const Case& c = GetParam();
  // 72 rows: two devices get bands of 40 and 32 rows, three of 32, 32 and 8.
  const Scene scene = small_scene(c.scene, 48, 72, c.tweak);
  const std::vector<float> one = render_on(1, scene, 2);
  expect_same_image(render_on(2, scene, 2), one, std::string(c.name) + " on 2 devices",
                    c.tolerance);
  expect_same_image(render_on(3, scene, 2), one, std::string(c.name) + " on 3 devices",
                    c.tolerance);
}

INSTANTIATE_TEST_SUITE_P(
    Estimators, MultiDeviceTest,
    ::testing::Values(
        Case{"knn", "cornell-caustics", {}, kKnnTolerance},
        Case{"vkde", "cornell-caustics",
             [](RenderSettings& s) { s.estimator = EstimatorKind::kVkde; }},
        Case{"sppm", "cornell-caustics",
             [](RenderSettings& s) { s.estimator = EstimatorKind::kSppm; }},
        Case{"path", "cornell-box", [](RenderSettings& s) { s.integrator = Integrator::kPath; }},
        Case{"knn_media", "fog-caustics", {}, kKnnTolerance},
        Case{"kd_tree_structure", "cornell-caustics",
             [](RenderSettings& s) { s.structure = StructureKind::kKdSah; }, kKnnTolerance}),
    [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

TEST(MultiDevice, FinalGatheringAgreesWithinTheNoise) {
  const Scene scene = small_scene("cornell-box", 64, 64, [](RenderSettings& s) {
    s.final_gather = true;
    s.final_gather_rays = 32;
  });
  const std::vector<float> one = render_on(1, scene, 4);
  const std::vector<float> two = render_on(2, scene, 4);
  ASSERT_EQ(one.size(), two.size());
  const ImageError e = image_error(two, one, 64, 64);
  EXPECT_NEAR(e.mean_ratio, 1.0, 0.02);
  EXPECT_LT(e.worst_region, 0.08);
}

// Changes between frames reach every device: lights, camera, a new size and a new structure.
TEST(MultiDevice, ChangesReachEveryDevice) {
  const Scene scene = small_scene("cornell-caustics", 40, 40);
  std::unique_ptr<Engine> one = engine_on(1), two = engine_on(2);
  ASSERT_TRUE(one && two);
  for (Engine* e : {one.get(), two.get()}) ASSERT_TRUE(e->load(scene).ok());
  EXPECT_EQ(two->devices().size(), 2u);

  std::vector<Light> lights = scene.lights;
  Light moved;
  moved.type = LightType::kPoint;
  moved.position = Vec3f(200, 400, 250);
  moved.intensity = Vec3f(40000, 40000, 40000);
  lights.push_back(moved);
  Camera camera = scene.camera;
  camera.position = camera.position + Vec3f(30, 0, 0);
  RenderSettings settings = scene.settings;
  settings.structure = StructureKind::kKdSah;
  const std::vector<std::function<bool(Engine&)>> changes = {
      [&](Engine& e) { return e.set_lights(lights).ok(); },
      [&](Engine& e) { return e.set_camera(camera).ok(); },
      [&](Engine& e) {
        return e.set_settings(scene.settings, {56, 70}).ok();
      },
      [&](Engine& e) { return e.set_settings(settings).ok(); },
  };
  for (size_t i = 0; i < changes.size(); ++i) {
    ASSERT_TRUE(changes[i](*one)) << "change " << i;
    ASSERT_TRUE(changes[i](*two)) << "change " << i;
    ASSERT_TRUE(one->render(1).ok());
    ASSERT_TRUE(two->render(1).ok());
    expect_same_image(image_of(*two), image_of(*one), "after change " + std::to_string(i),
                      kKnnTolerance);
    EXPECT_EQ(two->epochs().lights, one->epochs().lights);
    EXPECT_EQ(two->film_passes(), one->film_passes());
  }
  // Each device holds its own copy of the scene.
  EXPECT_GT(two->scene_stats().device_bytes, one->scene_stats().device_bytes);
}

// An image with fewer rows than a band per device leaves the last devices without rows: they
// trace their photons and render nothing.
TEST(MultiDevice, DevicesWithoutRowsStillTraceTheirShare) {
  const Scene scene = small_scene("cornell-caustics", 30, 20);
  std::unique_ptr<Engine> three = engine_on(3);
  ASSERT_TRUE(three);
  ASSERT_TRUE(three->load(scene).ok());
  absl::StatusOr<PassReport> report = three->render(2);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(report->photons_emitted, 2u * scene.settings.photons_per_pass);
  expect_same_image(image_of(*three), render_on(1, scene, 2), "20 rows on 3 devices",
                    kKnnTolerance);
}

}  // namespace
}  // namespace caustica
