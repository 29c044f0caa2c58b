// Whole-renderer checks against closed-form answers, determinism, and every bundled scene.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <oneapi/tbb/task_arena.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "absl/strings/str_format.h"
#include "renderer/engine.h"
#include "renderer/render/camera.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// The plane under a point light (analytic_scenes.h): 32 jittered passes average each pixel over
// its area, which matches the value at its centre to second order; no other surface, so no
// indirect light and no photons stored.
TEST(Analytic, DiffusePlaneUnderPointLightMatchesInverseSquareCosineLaw) {
  int checked = 0;
  const double worst = PlaneUnderPointLight{}.rendered_worst_error(
      R"({"photons": 10000, "passes": 1})", 32, 8, checked);
  EXPECT_GT(checked, 150);
  EXPECT_LT(worst, 0.01) << "largest relative error";
  RecordProperty("max_relative_error", absl::StrFormat("%.5f", worst));
  std::printf("plane under point light: max relative error %.4f%% over %d pixels\n", 100 * worst,
              checked);
}

// Inside the closed diffuse sphere (analytic_scenes.h): the photon maps carry every
// interreflection.
TEST(Analytic, InsideDiffuseSphereMatchesInterreflectionSeries) {
  const InsideDiffuseSphere sphere;
  auto engine = engine_with(sphere.scene(R"({"photons": 200000, "k": 64, "max_radius": 0.2,
                                             "max_photon_bounces": 40, "passes": 4})"));
  auto report = engine->render(4);
  ASSERT_TRUE(report.ok()) << report.status();
  const double mean = InsideDiffuseSphere::mean(engine->image_linear());
  const double expected = sphere.expected();
  const double error = std::fabs(mean - expected) / expected;
  EXPECT_LT(error, 0.03) << "mean " << mean << " expected " << expected;
  std::printf("inside diffuse sphere: mean radiance %.5f, analytic %.5f, relative error %.3f%%\n",
              mean, expected, 100 * error);
  EXPECT_GT(report->global_photons, 0u);
  EXPECT_EQ(report->caustic_photons, 0u);  // no specular surface, so no caustic paths
}

std::string scene_path(const char* name) {
  return std::string(CAUSTICA_SCENES_DIR) + "/" + name + "/scene.json";
}

std::vector<float> render_small(const char* name, uint32_t seed, uint32_t passes = 1,
                                int width = 48, int height = 40, uint32_t photons = 20000,
                                StructureKind structure = kDefaultStructure) {
  absl::StatusOr<Scene> scene = load_scene(scene_path(name));
  EXPECT_TRUE(scene.ok()) << scene.status();
  if (!scene.ok()) return {};
  scene->camera.width = width;
  scene->camera.height = height;
  scene->settings.photons_per_pass = photons;
  scene->settings.seed = seed;
  scene->settings.structure = structure;
  auto engine = engine_with(*scene);
  EXPECT_TRUE(engine->render(passes).ok());
  const std::span<const float> image = engine->image_linear();
  return {image.begin(), image.end()};
}

TEST(Determinism, SameSeedGivesBitIdenticalImage) {
  std::vector<float> a = render_small("cornell-caustics", 7, 2);
  std::vector<float> b = render_small("cornell-caustics", 7, 2);
  ASSERT_FALSE(a.empty());
  ASSERT_EQ(a.size(), b.size());  // a failed render is empty, and memcmp would read past it
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(float)));
  std::vector<float> c = render_small("cornell-caustics", 8, 2);
  ASSERT_EQ(a.size(), c.size());
  EXPECT_NE(0, std::memcmp(a.data(), c.data(), a.size() * sizeof(float)));
}

// Threads append the gather requests in whatever order their walks end; the image must not
// depend on it. Large enough that the mirror sphere shrinks several pixels onto one grid cell,
// whose requests tie in the Hilbert sort (with the requests taken in append order, one or two
// values of such an image changed in their last bit from run to run).
TEST(Determinism, SameImageOnOneThreadAsOnEvery) {
  auto render_on = [](int threads) {
    std::vector<float> image;
    tbb::task_arena(threads).execute(
        [&] { image = render_small("cornell-caustics", 1, 2, 192, 144, 50000); });
    return image;
  };
  const std::vector<float> one = render_on(1);
  ASSERT_FALSE(one.empty());
  for (int run = 0; run < 2; ++run) {
    const std::vector<float> every = render_on(tbb::task_arena::automatic);
    ASSERT_EQ(one.size(), every.size());
    EXPECT_EQ(0, std::memcmp(one.data(), every.data(), one.size() * sizeof(float)))
        << "run " << run;
  }
}

TEST(BundledScenes, EveryOneLoadsAndRendersSmall) {
  int scenes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(CAUSTICA_SCENES_DIR)) {
    if (!std::filesystem::exists(entry.path() / "scene.json")) continue;
    std::string name = entry.path().filename().string();
    SCOPED_TRACE(name);
    std::vector<float> image = render_small(name.c_str(), 1);
    ASSERT_EQ(image.size(), 48u * 40u * 4u);
    double sum = 0;
    for (float v : image) {
      ASSERT_TRUE(std::isfinite(v));
      ASSERT_GE(v, 0.0f);
      sum += v;
    }
    EXPECT_GT(sum, 48 * 40) << "image is black";  // alpha alone adds 1 per pixel
    ++scenes;
  }
  EXPECT_GE(scenes, 3);
}

// Root-mean-square difference of two RGBA images' colour channels, relative to the first's
// root-mean-square value.
double relative_rmse(const std::vector<float>& a, const std::vector<float>& b) {
  double diff = 0, ref = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (i % 4 == 3) continue;
    diff += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
    ref += double(a[i]) * a[i];
  }
  return std::sqrt(diff / ref);
}

// Every structure finds the same hits (accel/structure_test.cc) but may break an exact tie
// between coincident triangles another way, which sends a photon path elsewhere: the images agree
// to well under the noise of a pass.
TEST(BundledScenes, EveryStructureRendersTheImageOfTheDefault) {
  for (const char* name : {"cornell-box", "cornell-caustics", "ring"}) {
    const std::vector<float> reference = render_small(name, 3, 2, 64, 48, 20000, kDefaultStructure);
    ASSERT_FALSE(reference.empty());
    for (StructureKind kind : kStructureKinds) {
      SCOPED_TRACE(std::string(name) + " " + structure_kind_name(kind));
      const std::vector<float> image = render_small(name, 3, 2, 64, 48, 20000, kind);
      ASSERT_EQ(image.size(), reference.size());
      const double error = relative_rmse(reference, image);
      std::printf("%s, %s: relative RMSE against %s %.5f%%\n", name, structure_kind_name(kind),
                  structure_kind_name(kDefaultStructure), 100 * error);
      EXPECT_LT(error, 0.002);
    }
  }
}

// A new structure is a geometry change: the geometry epoch moves, "geometry" is reported with its
// build time, and the engine renders what an engine loaded with that structure renders.
TEST(Engine, StructureChangeRebuildsTheGeometryAndRendersAsIfLoadedWithIt) {
  absl::StatusOr<Scene> scene = load_scene(scene_path("cornell-caustics"));
  ASSERT_TRUE(scene.ok());
  scene->camera.width = 40;
  scene->camera.height = 32;
  scene->settings.photons_per_pass = 5000;
  auto engine = engine_with(*scene);
  ASSERT_TRUE(engine->render(1).ok());
  const Epochs before = engine->epochs();
  EXPECT_EQ(engine->scene_stats().structure, StructureKind::kLbvh4);
  RenderSettings settings = scene->settings;
  settings.structure = StructureKind::kBinnedSah;
  auto report = engine->set_settings(settings);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_THAT(report->rebuilt, testing::ElementsAre("geometry", "film", "photon_maps"));
  EXPECT_GT(report->timings.structure_build_ms, 0.0);
  EXPECT_EQ(engine->epochs().geometry, before.geometry + 1);
  EXPECT_EQ(engine->epochs().settings, before.settings + 1);
  const SceneStats stats = engine->scene_stats();
  EXPECT_EQ(stats.structure, StructureKind::kBinnedSah);
  EXPECT_GT(stats.structure_nodes, 0u);
  EXPECT_GT(stats.structure_bytes, 0u);
  EXPECT_GT(stats.structure_sah_cost, 1.0);
  ASSERT_TRUE(engine->render(2).ok());

  Scene loaded_with = *scene;
  loaded_with.settings.structure = StructureKind::kBinnedSah;
  auto fresh = engine_with(loaded_with);
  ASSERT_TRUE(fresh->render(2).ok());
  const std::span<const float> a = engine->image_linear(), b = fresh->image_linear();
  EXPECT_EQ(std::vector<float>(a.begin(), a.end()), std::vector<float>(b.begin(), b.end()));
  // The same settings again rebuild nothing but the film.
  auto again = engine->set_settings(settings);
  ASSERT_TRUE(again.ok());
  EXPECT_THAT(again->rebuilt, testing::ElementsAre("film"));
  EXPECT_EQ(engine->epochs().geometry, before.geometry + 1);
}

TEST(Engine, LightChangeRestartsAccumulationAndBumpsEpoch) {
  absl::StatusOr<Scene> scene = load_scene(scene_path("cornell-box"));
  ASSERT_TRUE(scene.ok());
  scene->camera.width = scene->camera.height = 16;
  scene->settings.photons_per_pass = 2000;
  auto engine = engine_with(*scene);
  ASSERT_TRUE(engine->render(2).ok());
  uint64_t lights_epoch = engine->epochs().lights;
  std::vector<Light> lights = {Light{"key", LightType::kPoint, Vec3f(278, 400, 279),
                                     Vec3f(0, -1, 0), Vec3f(1e5f, 1e5f, 1e5f)}};
  ASSERT_TRUE(engine->set_lights(lights).ok());
  EXPECT_EQ(engine->epochs().lights, lights_epoch + 1);
  auto report = engine->render(1);
  ASSERT_TRUE(report.ok());
  EXPECT_EQ(report->total_passes, 1u);
  // A light with negative intensity is refused and changes nothing.
  lights[0].intensity = Vec3f(-1, 0, 0);
  EXPECT_FALSE(engine->set_lights(lights).ok());
  EXPECT_EQ(engine->epochs().lights, lights_epoch + 1);
}

// The photon maps a light change traces ahead of time serve the next pass exactly as if that pass
// had traced them itself: the image equals a fresh engine loaded with the new lights.
TEST(Engine, LightChangeTracesPhotonsAheadWithoutChangingTheImage) {
  absl::StatusOr<Scene> scene = load_scene(scene_path("cornell-box"));
  ASSERT_TRUE(scene.ok());
  scene->camera.width = scene->camera.height = 16;
  scene->settings.photons_per_pass = 3000;
  std::vector<Light> lights = {Light{"key", LightType::kPoint, Vec3f(278, 400, 279),
                                     Vec3f(0, -1, 0), Vec3f(2e5f, 1e5f, 1e5f)}};
  auto updated = engine_with(*scene);
  ASSERT_TRUE(updated->render(1).ok());
  auto report = updated->set_lights(lights);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_THAT(report->rebuilt, testing::ElementsAre("lights", "film", "photon_maps"));
  EXPECT_EQ(report->epochs.lights, updated->epochs().lights);
  EXPECT_EQ(report->photons_emitted, 3000u);
  EXPECT_GT(report->caustic_photons + report->global_photons, 0u);
  EXPECT_GT(report->timings.photon_trace_ms, 0.0);
  auto pass = updated->render(2);
  ASSERT_TRUE(pass.ok());
  EXPECT_EQ(pass->photons_emitted, 3000u);  // only the second pass traced its own

  Scene relit = *scene;
  relit.lights = lights;
  auto fresh = engine_with(relit);
  ASSERT_TRUE(fresh->render(2).ok());
  const std::span<const float> a = updated->image_linear(), b = fresh->image_linear();
  EXPECT_EQ(std::vector<float>(a.begin(), a.end()), std::vector<float>(b.begin(), b.end()));
}

// A grey quad under a point light, 8 x 8 pixels.
constexpr char kGreyQuad[] = R"({
    "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "fov": 30, "width": 8, "height": 8},
    "settings": {"photons": 1000},
    "materials": {"grey": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
    "lights": [{"type": "point", "position": [0, 0, 1], "intensity": [1, 1, 1]}],
    "shapes": [{"type": "quad", "material": "grey",
                "vertices": [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]}]
  })";

// Updates are checked without the meshes: each refusal names its field and changes nothing.
TEST(Engine, RefusedUpdatesNameTheFieldAndChangeNothing) {
  Scene scene = parse_or_die(kGreyQuad);
  auto engine = engine_with(scene);
  const Epochs before = engine->epochs();
  // No point light and no emissive triangle would leave the scene dark.
  auto dark = engine->set_lights({});
  EXPECT_EQ(dark.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(dark.status().message()), testing::HasSubstr("no light"));
  Camera camera = scene.camera;
  camera.width = 0;
  auto no_pixels = engine->set_camera(camera);
  EXPECT_THAT(std::string(no_pixels.status().message()), testing::HasSubstr("camera.width"));
  RenderSettings settings = scene.settings;
  settings.k_nearest = 0;
  auto no_k = engine->set_settings(settings);
  EXPECT_THAT(std::string(no_k.status().message()), testing::HasSubstr("settings.k"));
  EXPECT_EQ(engine->epochs().lights, before.lights);
  EXPECT_EQ(engine->epochs().camera, before.camera);
  EXPECT_EQ(engine->epochs().settings, before.settings);
  EXPECT_EQ(engine->scene().lights.size(), 1u);
}

// Settings and the film's size change in one call: together, or not at all. A refused size, a
// refused setting, or a film beyond the memory budget leaves the settings, the camera, the film's
// passes and the epochs as they were; the film's passes restart only with a change.
TEST(Engine, SettingsAndSizeChangeTogetherOrNotAtAll) {
  const Scene scene = parse_or_die(kGreyQuad);
  auto engine =
      Engine::create({.device = DeviceKind::kCpu, .memory_budget_bytes = size_t{64} << 20});
  ASSERT_TRUE(engine.ok());
  ASSERT_TRUE((*engine)->load(scene).ok());
  Engine& e = **engine;
  ASSERT_TRUE(e.render(3).ok());
  EXPECT_EQ(e.film_passes(), 3u);
  const Epochs before = e.epochs();
  RenderSettings more_k = scene.settings;
  more_k.k_nearest = scene.settings.k_nearest + 8;

  auto expect_unchanged = [&](const absl::StatusOr<RebuildReport>& refused, absl::StatusCode code,
                              const std::string& message) {
    EXPECT_EQ(refused.status().code(), code) << refused.status();
    EXPECT_THAT(std::string(refused.status().message()), testing::HasSubstr(message));
    EXPECT_EQ(e.scene().settings.k_nearest, scene.settings.k_nearest);
    EXPECT_EQ(e.scene().camera.width, scene.camera.width);
    EXPECT_EQ(e.scene().camera.height, scene.camera.height);
    EXPECT_EQ(e.film_passes(), 3u);
    EXPECT_EQ(e.epochs().settings, before.settings);
    EXPECT_EQ(e.epochs().camera, before.camera);
  };
  expect_unchanged(e.set_settings(more_k, {.width = 1u << 20}), absl::StatusCode::kInvalidArgument,
                   "width: 1048576 is outside [1, ");
  RenderSettings no_k = more_k;
  no_k.k_nearest = 0;
  expect_unchanged(e.set_settings(no_k, {.width = 64, .height = 48}),
                   absl::StatusCode::kInvalidArgument, "settings.k");
  // 4096 x 4096 float RGBA accumulators are 256 MiB, beyond the budget.
  expect_unchanged(e.set_settings(more_k, {.width = 4096, .height = 4096}),
                   absl::StatusCode::kResourceExhausted, "");
  ASSERT_TRUE(e.render(1).ok());
  EXPECT_EQ(e.film_passes(), 4u);

  absl::StatusOr<RebuildReport> changed = e.set_settings(more_k, {.width = 64});
  ASSERT_TRUE(changed.ok()) << changed.status();
  EXPECT_EQ(e.scene().settings.k_nearest, more_k.k_nearest);
  EXPECT_EQ(e.scene().camera.width, 64);
  EXPECT_EQ(e.scene().camera.height, scene.camera.height);  // 0 kept it
  EXPECT_EQ(e.film_passes(), 0u);
  EXPECT_EQ(changed->epochs.settings, before.settings + 1);
  EXPECT_EQ(changed->epochs.camera, before.camera + 1);
  ASSERT_TRUE(e.render(1).ok());
  EXPECT_EQ(e.image_linear().size(), size_t{64} * scene.camera.height * 4);
}

// A bad medium is named, and the engine keeps the scene it had.
TEST(Engine, RefusesABadMediumAndKeepsItsScene) {
  auto engine = engine_with(parse_or_die(kGreyQuad));
  Scene foggy = parse_or_die(kGreyQuad);
  Medium fog;
  fog.name = "fog";
  fog.absorption = Vec3f(0.1f);
  fog.scattering = Vec3f(0.2f);
  fog.asymmetry = 1.0f;
  foggy.media.push_back(fog);
  foggy.medium = 0;
  EXPECT_THAT(std::string(engine->load(foggy).status().message()),
              testing::HasSubstr("media.fog.g: 1 is outside (-1, 1)"));
  EXPECT_TRUE(engine->scene().media.empty());
  EXPECT_TRUE(engine->render(1).ok());
}

TEST(Engine, EnginesSharingABackendShareOneBudget) {
  absl::StatusOr<Scene> scene = load_scene(scene_path("cornell-box"));
  ASSERT_TRUE(scene.ok());
  auto backend = make_backend(DeviceKind::kCpu, size_t{1} << 30);
  ASSERT_TRUE(backend.ok());
  auto first = Engine::create({.backend = *backend});
  auto second = Engine::create({.backend = *backend});
  ASSERT_TRUE(first.ok() && second.ok());
  ASSERT_TRUE((*first)->load(*scene).ok());
  const size_t one = (*backend)->bytes_in_use();
  EXPECT_GE(one, (*first)->scene_stats().device_bytes);
  ASSERT_TRUE((*second)->load(*scene).ok());
  EXPECT_EQ((*backend)->bytes_in_use(), 2 * one);
  first->reset();
  EXPECT_EQ((*backend)->bytes_in_use(), one);
}

TEST(Engine, MemoryBudgetOverrunIsResourceExhausted) {
  absl::StatusOr<Scene> scene = load_scene(scene_path("cornell-box"));
  ASSERT_TRUE(scene.ok());
  auto engine = Engine::create({.device = DeviceKind::kCpu, .memory_budget_bytes = 4096});
  ASSERT_TRUE(engine.ok());
  auto loaded = (*engine)->load(*scene);
  EXPECT_EQ(loaded.status().code(), absl::StatusCode::kResourceExhausted) << loaded.status();
}

}  // namespace
}  // namespace caustica
