// SPPM (settings.estimator "sppm") against closed forms, its statistics' lifetime, and its radius
// rules.
#include "renderer/photon/sppm.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <span>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "renderer/render/visible_points.h"
#include "renderer/resident/resident_scene.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// Direct light only: the visible points' shadow rays, and no photon stored.
TEST(Sppm, DiffusePlaneUnderPointLightMatchesInverseSquareCosineLaw) {
  int checked = 0;
  const double worst = PlaneUnderPointLight{}.rendered_worst_error(
      R"({"photons": 10000, "estimator": "sppm"})", 32, 8, checked);
  EXPECT_GT(checked, 150);
  EXPECT_LT(worst, 0.01) << "largest relative error";
  std::printf("sppm, plane under point light: max relative error %.4f%% over %d pixels\n",
              100 * worst, checked);
}

// Every interreflection comes from the photons; both radius rules converge to the series.
class SppmSphere : public testing::TestWithParam<const char*> {};

TEST_P(SppmSphere, MatchesInterreflectionSeries) {
  const InsideDiffuseSphere sphere;
  auto engine = engine_with(sphere.scene(absl::StrFormat(
      R"({"photons": 100000, "k": 64, "estimator": "sppm", "sppm_radius": "%s"})", GetParam())));
  ASSERT_TRUE(engine->render(16).ok());
  const double mean = InsideDiffuseSphere::mean(engine->image_linear());
  const double error = std::fabs(mean - sphere.expected()) / sphere.expected();
  EXPECT_LT(error, 0.01) << "mean " << mean << " expected " << sphere.expected();
  std::printf("sppm (%s radius) inside diffuse sphere: relative error %.3f%%\n", GetParam(),
              100 * error);
}

INSTANTIATE_TEST_SUITE_P(Rules, SppmSphere, testing::Values("pixel", "global"));

// The k-nearest estimator with the default path lengths (Russian roulette, the cap a safety net).
TEST(Knn, InsideDiffuseSphereMatchesInterreflectionSeriesWithDefaultPathLengths) {
  const InsideDiffuseSphere sphere;
  auto engine = engine_with(sphere.scene(R"({"photons": 100000, "k": 64, "max_radius": 0.2})"));
  ASSERT_TRUE(engine->render(8).ok());
  const double mean = InsideDiffuseSphere::mean(engine->image_linear());
  const double error = std::fabs(mean - sphere.expected()) / sphere.expected();
  EXPECT_LT(error, 0.01) << "mean " << mean << " expected " << sphere.expected();
  std::printf("knn inside diffuse sphere: relative error %.3f%%\n", 100 * error);
}

std::vector<float> image_of(Engine& engine) {
  const std::span<const float> image = engine.image_linear();
  return {image.begin(), image.end()};
}

Scene small_caustics(const std::string& estimator) {
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/cornell-caustics/scene.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  scene->camera.width = 40;
  scene->camera.height = 32;
  scene->settings.photons_per_pass = 20000;
  scene->settings.estimator = *parse_kind<EstimatorKind>(estimator);
  return *scene;
}

// A light change forgets the statistics: the image after it is the image of an engine that
// started with the new lights.
TEST(Sppm, LightChangeResetsTheStatistics) {
  Scene scene = small_caustics("sppm");
  auto engine = engine_with(scene);
  ASSERT_TRUE(engine->render(3).ok());
  Light point;
  point.position = {278, 450, 279};
  point.intensity = {40000, 40000, 40000};
  const std::vector<Light> lights = {point};
  ASSERT_TRUE(engine->set_lights(lights).ok());
  ASSERT_TRUE(engine->render(3).ok());
  scene.lights = lights;
  auto fresh = engine_with(scene);
  ASSERT_TRUE(fresh->render(3).ok());
  EXPECT_EQ(image_of(*engine), image_of(*fresh));
}

// So does a camera change, and a change of estimator gives the image of an engine loaded with it.
TEST(Sppm, CameraAndEstimatorChangesStartAgain) {
  Scene scene = small_caustics("knn");
  auto engine = engine_with(scene);
  ASSERT_TRUE(engine->render(2).ok());
  RenderSettings settings = scene.settings;
  settings.estimator = EstimatorKind::kSppm;
  ASSERT_TRUE(engine->set_settings(settings).ok());
  ASSERT_TRUE(engine->render(2).ok());
  scene.camera.position.y += 10.0f;
  ASSERT_TRUE(engine->set_camera(scene.camera).ok());
  ASSERT_TRUE(engine->render(3).ok());
  scene.settings = settings;
  auto fresh = engine_with(scene);
  ASSERT_TRUE(fresh->render(3).ok());
  EXPECT_EQ(image_of(*engine), image_of(*fresh));
}

// A pixel's estimate is its own: the same seed gives the same image, on one thread as on all.
TEST(Sppm, SameSeedGivesBitIdenticalImage) {
  const Scene scene = small_caustics("sppm");
  auto a = engine_with(scene);
  auto b = engine_with(scene);
  ASSERT_TRUE(a->render(3).ok());
  ASSERT_TRUE(b->render(3).ok());
  EXPECT_EQ(image_of(*a), image_of(*b));
}

// The chains as ray queues meet the same points with the same light as one chain a thread, to the
// bit; a structure that answers batches only (dacrt) takes the queues and renders lbvh4's image.
TEST(Sppm, VisiblePointsThroughRayQueuesAreTheSame) {
  const Scene scene = small_caustics("sppm");
  auto backend = make_cpu_backend(size_t(1) << 30);
  const ResidentScene resident = ResidentScene::upload(*backend, scene);
  const PinholeCamera camera = PinholeCamera::from(scene.camera);
  const size_t pixels = size_t(scene.camera.width) * scene.camera.height;
  std::vector<VisiblePoint> points[2];
  std::vector<Vec3f> light[2];
  for (int queues = 0; queues < 2; ++queues) {
    Buffer<VisiblePoint> p(*backend, pixels);
    Buffer<Vec3f> l(*backend, pixels);
    l.fill_zero();
    VisiblePointSettings settings;
    settings.pass = 3;
    settings.ray_queues = queues == 1;
    trace_visible_points(*backend, resident, camera, settings, p.data(), l.data());
    points[queues] = p.download();
    light[queues] = l.download();
  }
  size_t seen = 0;
  for (size_t i = 0; i < pixels; ++i) {
    EXPECT_EQ(points[0][i].position, points[1][i].position) << "pixel " << i;
    EXPECT_EQ(points[0][i].weight, points[1][i].weight) << "pixel " << i;
    EXPECT_EQ(light[0][i], light[1][i]) << "pixel " << i;
    seen += max_component(points[0][i].weight) > 0.0f;
  }
  EXPECT_GT(seen, pixels / 2);

  Scene dacrt = scene;
  dacrt.settings.structure = StructureKind::kDacrt;
  auto by_queues = engine_with(dacrt);
  auto by_thread = engine_with(scene);
  ASSERT_TRUE(by_queues->render(2).ok());
  ASSERT_TRUE(by_thread->render(2).ok());
  const std::vector<float> a = image_of(*by_queues), b = image_of(*by_thread);
  double difference = 0, norm = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    difference += (a[i] - b[i]) * (a[i] - b[i]);
    norm += b[i] * b[i];
  }
  EXPECT_LT(std::sqrt(difference / norm), 0.002) << "dacrt against lbvh4";
}

TEST(Sppm, GlobalShrinkFollowsKnausZwicker) {
  EXPECT_DOUBLE_EQ(sppm_global_shrink(1, 0.7f), 1.0);
  EXPECT_NEAR(sppm_global_shrink(2, 0.7f), 1.7 / 2.0, 1e-7);
  EXPECT_NEAR(sppm_global_shrink(3, 0.7f), 1.7 / 2.0 * 2.7 / 3.0, 1e-7);
  // r_i^2 falls as i^(alpha - 1): the ratio over two decades is about 100^(-0.3).
  const double decade = sppm_global_shrink(10000, 0.7f) / sppm_global_shrink(100, 0.7f);
  EXPECT_NEAR(decade, std::pow(100.0, -0.3), 0.01 * std::pow(100.0, -0.3));
}

}  // namespace
}  // namespace caustica
