// The path integrator (settings.integrator "path") against closed-form answers: direct light from a
// point light, direct light from an area light (found both by shadow rays and by bounces, the two
// weighed by multiple importance sampling), and every interreflection inside a closed sphere; and
// how the engine runs it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "absl/strings/str_format.h"
#include "renderer/engine.h"
#include "renderer/render/camera.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// The plane under a point light (analytic_scenes.h): one bounce sees nothing but the light, so
// every pixel is what the photon integrator makes it.
TEST(PathTracer, DiffusePlaneUnderPointLightMatchesInverseSquareCosineLaw) {
  PlaneUnderPointLight plane;
  plane.size = 96;
  PassReport report;
  report.photons_emitted = 1;
  int checked = 0;
  const double worst =
      plane.rendered_worst_error(R"({"integrator": "path"})", 32, 6, checked, &report);
  EXPECT_EQ(report.photons_emitted, 0u);  // the path integrator traces no photons
  EXPECT_GT(checked, 150);
  EXPECT_LT(worst, 0.01) << "largest relative error";
  std::printf("path tracer, plane under point light: max relative error %.4f%% over %d pixels\n",
              100 * worst, checked);
}

// The form factor from a point of a plane to a parallel rectangle [x0, x1] x [y0, y1] at height h
// above it, the coordinates relative to the point: the corner formula, odd in each coordinate,
// summed over the rectangle's corners.
double rectangle_form_factor(double x0, double x1, double y0, double y1, double h) {
  auto corner = [&](double x, double y) {
    const double a = x / h, b = y / h;
    const double sa = std::sqrt(1 + a * a), sb = std::sqrt(1 + b * b);
    return (a / sa * std::atan(b / sa) + b / sb * std::atan(a / sb)) / (2 * kPi);
  };
  return corner(x1, y1) - corner(x0, y1) - corner(x1, y0) + corner(x0, y0);
}

// A diffuse floor under a square area light facing it: the radiance at a floor point is
// rho * Le * F, F the point's form factor to the square. Shadow rays and bounces that hit the light
// both find it, each weighed by the power heuristic, so a weight wrong in either would move the
// mean.
TEST(PathTracer, FloorUnderAreaLightMatchesTheFormFactor) {
  const float rho = 0.7f, le = 2.0f, half = 0.5f, h = 1.0f;
  const Scene scene = floor_under_area_light(R"({"integrator": "path", "seed": 5})", rho, le, half,
                                             h, Vec3f(0.2f, -2.5f, 1.0f), 64, 48);
  auto engine = engine_with(scene);
  ASSERT_TRUE(engine->render(256).ok());
  const std::span<const float> image = engine->image_linear();
  const PinholeCamera cam = PinholeCamera::from(scene.camera);
  double sum_ratio = 0, worst = 0;
  int checked = 0;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      Vec3f p;
      if (!plane_point(cam, x, y, p) || std::fabs(p.x) > 1.5f || std::fabs(p.y) > 1.5f) continue;
      const double expected =
          rho * le * rectangle_form_factor(-half - p.x, half - p.x, -half - p.y, half - p.y, h);
      const double ratio = image[4 * (y * 64 + x)] / expected;
      sum_ratio += ratio;
      worst = std::max(worst, std::fabs(ratio - 1));
      ++checked;
    }
  }
  ASSERT_GT(checked, 1000);
  const double mean_error = std::fabs(sum_ratio / checked - 1);
  EXPECT_LT(mean_error, 0.01) << "mean of got / expected over " << checked << " pixels";
  EXPECT_LT(worst, 0.15) << "a pixel's noise after 256 paths";
  std::printf(
      "path tracer, floor under area light: mean relative error %.3f%%, worst pixel %.1f%%, "
      "%d pixels\n",
      100 * mean_error, 100 * worst, checked);
}

// Inside the closed diffuse sphere (analytic_scenes.h): every bounce adds rho times the last,
// which only paths that Russian roulette lets run long enough add up to.
TEST(PathTracer, InsideDiffuseSphereMatchesInterreflectionSeries) {
  const InsideDiffuseSphere sphere;
  auto engine = engine_with(sphere.scene(R"({"integrator": "path"})"));
  ASSERT_TRUE(engine->render(16).ok());
  const double mean = InsideDiffuseSphere::mean(engine->image_linear());
  const double error = std::fabs(mean - sphere.expected()) / sphere.expected();
  EXPECT_LT(error, 0.01) << "mean " << mean << " expected " << sphere.expected();
  std::printf("path tracer, inside diffuse sphere: mean %.5f, analytic %.5f, error %.3f%%\n", mean,
              sphere.expected(), 100 * error);
}

const char* kCornellLike = R"({
    "camera": {"position": [0, 1, 3], "look_at": [0, 1, 0], "fov": 50, "width": 24, "height": 16},
    "settings": {"integrator": "path", "photons": 5000},
    "materials": {"white": {"type": "diffuse", "albedo": [0.7, 0.7, 0.7]},
                  "lamp": {"type": "emissive", "radiance": [4, 4, 4]}},
    "lights": [{"type": "point", "position": [0.3, 1.5, 0.5], "intensity": [1, 1, 1]}],
    "shapes": [{"type": "quad", "material": "white",
                "vertices": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]},
               {"type": "quad", "material": "white",
                "vertices": [[-1, 0, -1], [1, 0, -1], [1, 2, -1], [-1, 2, -1]]},
               {"type": "quad", "material": "lamp",
                "vertices": [[-0.3, 1.9, -0.3], [0.3, 1.9, -0.3], [0.3, 1.9, 0.3], [-0.3, 1.9, 0.3]]}]
  })";

// A structure that answers batches only cannot serve a path traced one ray at a time: a scene
// asking for both is refused naming the setting, as is a change to it, and the engine renders on.
TEST(PathTracer, BatchOnlyStructureIsRefusedNamingIt) {
  Scene scene = parse_or_die(kCornellLike);
  scene.settings.structure = StructureKind::kDacrt;
  auto engine = Engine::create({});
  ASSERT_TRUE(engine.ok()) << engine.status();
  const absl::Status loaded = (*engine)->load(scene).status();
  EXPECT_EQ(loaded.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(loaded.message()),
              ::testing::HasSubstr("settings.structure: the path integrator traces one ray at a "
                                   "time, and the structure dacrt answers batches only"));
  scene.settings.structure = StructureKind::kLbvh4;
  ASSERT_TRUE((*engine)->load(scene).ok());
  RenderSettings settings = scene.settings;
  settings.structure = StructureKind::kDacrt;
  auto refused = (*engine)->set_settings(settings);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(refused.status().message()),
              ::testing::HasSubstr("structure dacrt answers batches only"));
  EXPECT_TRUE((*engine)->render(1).ok());
}

// The path integrator traces no photons, not even ahead of a light change; a change to the photon
// integrator traces them again, and back again the image is the path tracer's as before.
TEST(PathTracer, EngineTracesNoPhotonsForItAndSwitchesIntegrators) {
  const Scene scene = parse_or_die(kCornellLike);
  auto engine = engine_with(scene);
  ASSERT_TRUE(engine->render(2).ok());
  const std::vector<float> first(engine->image_linear().begin(), engine->image_linear().end());
  auto lights = engine->set_lights(scene.lights);
  ASSERT_TRUE(lights.ok()) << lights.status();
  EXPECT_THAT(lights->rebuilt, ::testing::Not(::testing::Contains("photon_maps")));
  EXPECT_EQ(lights->photons_emitted, 0u);

  RenderSettings photon = scene.settings;
  photon.integrator = Integrator::kPhoton;
  ASSERT_TRUE(engine->set_settings(photon).ok());
  auto photon_pass = engine->render(1);
  ASSERT_TRUE(photon_pass.ok());
  EXPECT_GT(photon_pass->photons_emitted, 0u);

  EXPECT_GT(engine->scene_stats().photon_map_bytes, 0u);
  ASSERT_TRUE(engine->set_settings(scene.settings).ok());
  ASSERT_TRUE(engine->render(2).ok());
  EXPECT_EQ(engine->scene_stats().photon_map_bytes, 0u) << "no maps held for the path integrator";
  const std::vector<float> again(engine->image_linear().begin(), engine->image_linear().end());
  EXPECT_EQ(first, again);  // the same seed and passes: the same paths
}

}  // namespace
}  // namespace caustica
