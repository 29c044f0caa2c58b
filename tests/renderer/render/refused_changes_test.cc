// A refused change changes nothing (issue 41): every mutating call of the engine, refused by its
// checks, by the memory budget, or by any one of the device allocations it makes failing, returns
// the error and leaves the epochs, the scene, the device memory and the film as they were, so
// that the engine then renders, bit for bit, the image it rendered before.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include "absl/strings/str_format.h"
#include "renderer/engine.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// A CPU backend whose allocations are counted and one of which can be made to fail, as the device
// running out of memory would (Backend::allocate turns the bad_alloc into OutOfDeviceMemory). The
// CPU backend's own primitives allocate their scratch from the wrapped backend, uncounted.
class FailingBackend final : public Backend {
 public:
  explicit FailingBackend(size_t memory_budget_bytes)
      : Backend(memory_budget_bytes), cpu_(make_cpu_backend(std::numeric_limits<size_t>::max())) {}

  // The allocation after the next `successes` fails, and only that one; nullopt: none fails.
  void fail_after(std::optional<uint64_t> successes) {
    fail_at_ = successes ? std::optional(allocations_ + *successes) : std::nullopt;
  }
  uint64_t allocations() const { return allocations_; }

  DeviceKind kind() const override { return DeviceKind::kCpu; }
  DeviceInfo info() const override { return cpu_->info(); }
  void* allocate_host(size_t bytes) override { return cpu_->allocate_host(bytes); }
  void deallocate_host(void* p) noexcept override { cpu_->deallocate_host(p); }
  void copy_to_device(void* dst, const void* src, size_t bytes) override {
    cpu_->copy_to_device(dst, src, bytes);
  }
  void copy_to_host(void* dst, const void* src, size_t bytes) override {
    cpu_->copy_to_host(dst, src, bytes);
  }
  void copy_on_device(void* dst, const void* src, size_t bytes) override {
    cpu_->copy_on_device(dst, src, bytes);
  }
  void fill_bytes(void* dst, uint8_t value, size_t bytes) override {
    cpu_->fill_bytes(dst, value, bytes);
  }
  void synchronize() override { cpu_->synchronize(); }
  void sort_pairs(uint32_t* keys, uint32_t* values, size_t n, int end_bit) override {
    cpu_->sort_pairs(keys, values, n, end_bit);
  }
  void sort_pairs(uint64_t* keys, uint32_t* values, size_t n, int end_bit) override {
    cpu_->sort_pairs(keys, values, n, end_bit);
  }
  uint32_t exclusive_scan(const uint32_t* in, uint32_t* out, size_t n) override {
    return cpu_->exclusive_scan(in, out, n);
  }
  float exclusive_scan(const float* in, float* out, size_t n) override {
    return cpu_->exclusive_scan(in, out, n);
  }
  uint64_t reduce_sum(const uint32_t* in, size_t n) override { return cpu_->reduce_sum(in, n); }
  double reduce_sum(const float* in, size_t n) override { return cpu_->reduce_sum(in, n); }
  float reduce_max(const float* in, size_t n) override { return cpu_->reduce_max(in, n); }
  Aabb reduce_bounds(const Aabb* in, size_t n) override { return cpu_->reduce_bounds(in, n); }
  void reduce_bounds_to(const Aabb* in, size_t n, Aabb* out) override {
    cpu_->reduce_bounds_to(in, n, out);
  }
  size_t select_flagged(const uint32_t* in, const uint8_t* flags, size_t n,
                        uint32_t* out) override {
    return cpu_->select_flagged(in, flags, n, out);
  }
  size_t run_length_encode(const uint32_t* in, size_t n, uint32_t* unique_out,
                           uint32_t* counts_out) override {
    return cpu_->run_length_encode(in, n, unique_out, counts_out);
  }

 protected:
  // Called under Backend's memory lock, so the count needs none of its own.
  void* allocate_raw(size_t bytes) override {
    if (fail_at_ && allocations_ == *fail_at_) {
      fail_at_.reset();
      throw std::bad_alloc();
    }
    ++allocations_;
    return cpu_->allocate(bytes);
  }
  void deallocate_raw(void* p, size_t bytes) override { cpu_->deallocate(p, bytes); }

 private:
  std::unique_ptr<Backend> cpu_;
  uint64_t allocations_ = 0;
  std::optional<uint64_t> fail_at_;
};

constexpr uint32_t kPasses = 2;
constexpr size_t kLargeBudget = size_t{1} << 30;
// Room for the small scenes below, far too little for a film of 16384 x 16384 pixels.
constexpr size_t kSmallBudget = size_t{64} << 20;

// A Cornell box with a glass and a mirror sphere of few triangles, lit by its ceiling and a spot
// light, in fog when `fog`: caustic and global photons, area and spot lights, and media, with
// little to trace. 40 rows deal 32 to the first of two devices and 8 to the second.
Scene small_scene(bool fog) {
  return parse_or_die(absl::StrFormat(R"({
    "camera": {"position": [278, 273, -800], "look_at": [278, 273, -799], "fov": 39.3,
               "width": 32, "height": 40},
    "settings": {"photons": 500, "k": 16, "area_light_samples": 1},
    "materials": {
      "white": {"type": "diffuse", "albedo": [0.725, 0.71, 0.68]},
      "red": {"type": "diffuse", "albedo": [0.63, 0.065, 0.05]},
      "light": {"type": "emissive", "radiance": [17, 12, 4]},
      "glass": {"type": "dielectric", "ior": 1.5},
      "mirror": {"type": "mirror", "reflectance": [1, 1, 1]}
    },
    %s
    "lights": [{"name": "spot", "type": "spot", "position": [330, 540, 330],
                "direction": [0, -1, 0], "intensity": [240000, 220000, 170000],
                "inner_angle": 17, "outer_angle": 20}],
    "shapes": [
      {"type": "quad", "material": "white",
       "vertices": [[552.8, 0, 0], [0, 0, 0], [0, 0, 559.2], [549.6, 0, 559.2]]},
      {"type": "quad", "material": "white",
       "vertices": [[556, 548.8, 0], [556, 548.8, 559.2], [0, 548.8, 559.2], [0, 548.8, 0]]},
      {"type": "quad", "material": "white",
       "vertices": [[549.6, 0, 559.2], [0, 0, 559.2], [0, 548.8, 559.2], [556, 548.8, 559.2]]},
      {"type": "quad", "material": "red",
       "vertices": [[552.8, 0, 0], [549.6, 0, 559.2], [556, 548.8, 559.2], [556, 548.8, 0]]},
      {"type": "quad", "material": "light",
       "vertices": [[343, 548.7, 227], [343, 548.7, 332], [213, 548.7, 332], [213, 548.7, 227]]},
      {"type": "sphere", "material": "glass", "center": [370, 100, 350], "radius": 100,
       "rings": 6, "segments": 12},
      {"type": "sphere", "material": "mirror", "center": [180, 100, 200], "radius": 100,
       "rings": 6, "segments": 12}
    ]
  })",
                                      fog ? R"("media": {"fog": {"type": "homogeneous",
                                                    "absorption": [0.0001, 0.0001, 0.0001],
                                                    "scattering": [0.0015, 0.0015, 0.0015],
                                                    "g": 0.3}},
                                           "medium": "fog",)"
                                          : ""));
}

// An engine over `devices` failing backends with `scene` loaded and rendered for kPasses passes.
struct TestEngine {
  std::vector<std::shared_ptr<FailingBackend>> backends;
  std::unique_ptr<Engine> engine;
};

TestEngine rendered_engine(const Scene& scene, size_t devices, size_t budget) {
  TestEngine t;
  EngineOptions options;
  for (size_t i = 0; i < devices; ++i) {
    t.backends.push_back(std::make_shared<FailingBackend>(budget));
    options.backends.push_back(t.backends.back());
  }
  absl::StatusOr<std::unique_ptr<Engine>> engine = Engine::create(options);
  EXPECT_TRUE(engine.ok()) << engine.status();
  if (!engine.ok()) return t;
  t.engine = *std::move(engine);
  const absl::StatusOr<RebuildReport> loaded = t.engine->load(scene);
  EXPECT_TRUE(loaded.ok()) << loaded.status();
  const absl::StatusOr<PassReport> rendered = t.engine->render(kPasses);
  EXPECT_TRUE(rendered.ok()) << rendered.status();
  if (!loaded.ok() || !rendered.ok()) t.engine.reset();
  return t;
}

// The image's values as their bits, so that images compare bit for bit.
std::vector<uint32_t> image_of(Engine& engine) {
  const std::span<const float> image = engine.image_linear();
  std::vector<uint32_t> bits(image.size());
  std::transform(image.begin(), image.end(), bits.begin(),
                 [](float v) { return std::bit_cast<uint32_t>(v); });
  return bits;
}

// Whether any colour value is above zero (alpha is 1 everywhere): a black image proves nothing.
bool lit(const std::vector<uint32_t>& image) {
  for (size_t i = 0; i < image.size(); ++i) {
    if (i % 4 != 3 && std::bit_cast<float>(image[i]) > 0) return true;
  }
  return false;
}

auto fields(const Camera& c) {
  return std::tie(c.position, c.look_at, c.up, c.vertical_fov_deg, c.width, c.height);
}
auto fields(const Light& l) {
  return std::tie(l.name, l.type, l.position, l.direction, l.intensity, l.inner_angle_deg,
                  l.outer_angle_deg);
}
auto fields(const Material& m) {
  return std::tie(m.name, m.type, m.color, m.ior, m.radiance, m.off);
}
auto fields(const RenderSettings& s) {
  return std::tie(s.photons_per_pass, s.k_nearest, s.max_radius, s.kernel, s.integrator,
                  s.estimator, s.sppm_alpha, s.sppm_radius, s.vkde_spread, s.final_gather,
                  s.final_gather_rays, s.final_gather_seeds, s.max_depth, s.max_photon_bounces,
                  s.area_light_samples, s.passes, s.seed, s.structure);
}
template <typename T>
bool same(const std::vector<T>& a, const std::vector<T>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (fields(a[i]) != fields(b[i])) return false;
  }
  return true;
}
bool same(const Epochs& a, const Epochs& b) {
  return std::tie(a.geometry, a.lights, a.camera, a.settings) ==
         std::tie(b.geometry, b.lights, b.camera, b.settings);
}

// What a refused change must leave as it was, read without touching the film, which a broken
// engine may have lost (image_linear would then read freed memory).
struct Observed {
  Epochs epochs;
  Camera camera;
  std::vector<Light> lights;
  std::vector<Material> materials;
  RenderSettings settings;
  uint32_t film_passes = 0;
  size_t device_bytes = 0;
  std::vector<size_t> bytes_in_use;  // per device
  StructureKind structure = kDefaultStructure;
};

Observed observe(const TestEngine& t) {
  const Engine& e = *t.engine;
  Observed o;
  o.epochs = e.epochs();
  o.camera = e.scene().camera;
  o.lights = e.scene().lights;
  o.materials = e.scene().materials;
  o.settings = e.scene().settings;
  o.film_passes = e.film_passes();
  o.device_bytes = e.scene_stats().device_bytes;
  for (const auto& backend : t.backends) o.bytes_in_use.push_back(backend->bytes_in_use());
  o.structure = e.scene_stats().structure;
  return o;
}

void expect_unchanged(const Observed& before, const Observed& after) {
  EXPECT_TRUE(same(after.epochs, before.epochs)) << "the epochs moved";
  EXPECT_TRUE(fields(after.camera) == fields(before.camera)) << "the camera changed";
  EXPECT_TRUE(same(after.lights, before.lights)) << "the lights changed";
  EXPECT_TRUE(same(after.materials, before.materials)) << "the materials changed";
  EXPECT_TRUE(fields(after.settings) == fields(before.settings)) << "the settings changed";
  EXPECT_EQ(after.structure, before.structure) << "the structure changed";
  EXPECT_EQ(after.film_passes, before.film_passes) << "the film lost its passes";
  EXPECT_EQ(after.device_bytes, before.device_bytes) << "the engine's device memory changed";
  EXPECT_EQ(after.bytes_in_use, before.bytes_in_use) << "device memory in use changed";
}

// After a refusal the film holds the image it held, and once restarted the engine renders it
// again: nothing in the scene, the structure, the lights' tables or the estimator moved.
void expect_same_images(TestEngine& t, const std::vector<uint32_t>& before) {
  Engine& e = *t.engine;
  EXPECT_EQ(image_of(e), before) << "the film changed";
  const absl::StatusOr<RebuildReport> restarted = e.set_camera(e.scene().camera);
  ASSERT_TRUE(restarted.ok()) << restarted.status();
  const absl::StatusOr<PassReport> rendered = e.render(kPasses);
  ASSERT_TRUE(rendered.ok()) << rendered.status();
  EXPECT_EQ(image_of(e), before) << "the engine renders another image than before";
}

using Change = std::function<absl::StatusOr<RebuildReport>(Engine&)>;

// Applies `change` to `t`, which must refuse it with `code`, and checks that nothing changed.
void expect_refused(TestEngine& t, const Change& change, absl::StatusCode code,
                    const std::vector<uint32_t>& before_image) {
  const Observed before = observe(t);
  const absl::StatusOr<RebuildReport> refused = change(*t.engine);
  for (const auto& backend : t.backends) backend->fail_after(std::nullopt);
  ASSERT_FALSE(refused.ok()) << "the change was not refused";
  EXPECT_EQ(refused.status().code(), code) << refused.status();
  const Observed after = observe(t);
  expect_unchanged(before, after);
  // A lost film would be read after it was freed.
  ASSERT_EQ(after.film_passes, before.film_passes);
  ASSERT_EQ(after.device_bytes, before.device_bytes);
  expect_same_images(t, before_image);
}

struct Case {
  const char* name;
  Change change;
  bool fog = false;
  size_t devices = 1;
};

Light point_light(Vec3f position) {
  Light l;
  l.name = "added";
  l.type = LightType::kPoint;
  l.position = position;
  l.intensity = Vec3f(40000, 30000, 20000);
  return l;
}

RenderSettings settings_of(const Engine& e, const std::function<void(RenderSettings&)>& tweak) {
  RenderSettings s = e.scene().settings;
  tweak(s);
  return s;
}

Change settings_change(std::function<void(RenderSettings&)> tweak, ImageSize size = {}) {
  return [tweak, size](Engine& e) { return e.set_settings(settings_of(e, tweak), size); };
}

Change camera_change(std::function<void(Camera&)> tweak) {
  return [tweak](Engine& e) {
    Camera c = e.scene().camera;
    tweak(c);
    return e.set_camera(c);
  };
}

// Changes the engine takes when memory allows, each of which allocates: each of its allocations
// is made to fail in turn. (A camera moved, or a setting of the gather or the integrator changed,
// allocates nothing.) On two devices, a few of them, one of each kind, so that the test stays
// short: there the second device's allocations fail after the first device made all of its own.
std::vector<Case> accepted_changes() {
  const Change added_light = [](Engine& e) {
    return e.set_lights({point_light(Vec3f(200, 400, 250))});
  };
  const Change emitter_off = [](Engine& e) {
    return e.set_lights({point_light(Vec3f(280, 500, 280))}, {{"light", std::nullopt, true}});
  };
  const Change camera_resized = camera_change([](Camera& c) {
    c.width = 48;
    c.height = 72;
  });
  const Change vkde =
      settings_change([](RenderSettings& s) { s.estimator = EstimatorKind::kVkde; });
  const Change structure_and_photons = settings_change([](RenderSettings& s) {
    s.structure = StructureKind::kBvh8;
    s.photons_per_pass = 800;
  });
  const Change settings_resized =
      settings_change([](RenderSettings& s) { s.k_nearest = 20; }, {48, 56});
  return {
      {"AddedLight", added_light},
      {"MovedLight",
       [](Engine& e) {
         std::vector<Light> lights = e.scene().lights;
         lights[0].position = lights[0].position + Vec3f(20, 0, 10);
         return e.set_lights(lights);
       },
       true},
      {"EmitterRadiance",
       [](Engine& e) {
         return e.set_lights(e.scene().lights, {{"light", Vec3f(30, 20, 10), std::nullopt}});
       }},
      {"EmitterOffWithALight", emitter_off},
      {"CameraResized", camera_resized},
      {"SettingsPhotons", settings_change([](RenderSettings& s) { s.photons_per_pass = 700; })},
      {"SettingsSeed", settings_change([](RenderSettings& s) { s.seed = 7; })},
      {"SettingsSppm",
       settings_change([](RenderSettings& s) { s.estimator = EstimatorKind::kSppm; })},
      {"SettingsVkde", vkde},
      {"StructureBinnedSah",
       settings_change([](RenderSettings& s) { s.structure = StructureKind::kBinnedSah; })},
      {"StructureAndPhotons", structure_and_photons},
      {"SettingsResized", settings_resized},
      {"MediaSettings", vkde, true},
      {"AddedLight", added_light, false, 2},
      {"EmitterOffWithALight", emitter_off, false, 2},
      {"CameraResized", camera_resized, false, 2},
      {"SettingsVkde", vkde, false, 2},
      {"StructureAndPhotons", structure_and_photons, false, 2},
      {"SettingsResized", settings_resized, false, 2},
  };
}

void PrintTo(const Case& c, std::ostream* os) { *os << c.name << " on " << c.devices; }

class AllocationFailure : public ::testing::TestWithParam<Case> {};

// Every allocation the change makes fails in turn; each time the change is refused and nothing
// changes. A fresh engine first counts the allocations of the change taken.
TEST_P(AllocationFailure, RefusesTheChangeAndKeepsTheImage) {
  const Case& c = GetParam();
  const Scene scene = small_scene(c.fog);
  TestEngine counting = rendered_engine(scene, c.devices, kLargeBudget);
  ASSERT_TRUE(counting.engine);
  FailingBackend& failing = *counting.backends.back();
  const uint64_t before_change = failing.allocations();
  const absl::StatusOr<RebuildReport> taken = c.change(*counting.engine);
  ASSERT_TRUE(taken.ok()) << taken.status();
  const uint64_t allocations = failing.allocations() - before_change;
  ASSERT_GT(allocations, 0u) << "a change that allocates nothing tests nothing here";

  TestEngine t = rendered_engine(scene, c.devices, kLargeBudget);
  ASSERT_TRUE(t.engine);
  const std::vector<uint32_t> before = image_of(*t.engine);
  ASSERT_TRUE(lit(before));
  for (uint64_t n = 0; n < allocations; ++n) {
    SCOPED_TRACE(testing::Message() << "allocation " << n + 1 << " of " << allocations
                                    << " on device " << c.devices - 1 << " fails");
    t.backends.back()->fail_after(n);
    expect_refused(t, c.change, absl::StatusCode::kResourceExhausted, before);
    if (HasFailure()) return;  // the first failing allocation says enough
  }
}

INSTANTIATE_TEST_SUITE_P(Changes, AllocationFailure, ::testing::ValuesIn(accepted_changes()),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           return std::string(info.param.name) + "On" +
                                  std::to_string(info.param.devices) + "Devices";
                         });

struct Refusal {
  const char* name;
  Change change;
  absl::StatusCode code;
  bool fog = false;
};

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();

// Changes refused by their checks, or by a memory budget too small for them.
const std::vector<Refusal>& refusals() {
  static const std::vector<Refusal> cases = {
      {"LightNotFinite", [](Engine& e) { return e.set_lights({point_light(Vec3f(kNan, 0, 0))}); },
       absl::StatusCode::kInvalidArgument},
      {"LightNegative",
       [](Engine& e) {
         Light l = point_light(Vec3f(200, 400, 250));
         l.intensity = Vec3f(1, -1, 1);
         return e.set_lights({l});
       },
       absl::StatusCode::kInvalidArgument},
      {"SpotAngles",
       [](Engine& e) {
         Light l = point_light(Vec3f(200, 400, 250));
         l.type = LightType::kSpot;
         l.inner_angle_deg = 50;
         l.outer_angle_deg = 200;
         return e.set_lights({l});
       },
       absl::StatusCode::kInvalidArgument},
      {"UnknownEmitter",
       [](Engine& e) {
         return e.set_lights({}, {{"lamp", Vec3f(1, 1, 1), std::nullopt}});
       },
       absl::StatusCode::kInvalidArgument},
      {"EmitterNotFinite",
       [](Engine& e) {
         return e.set_lights({}, {{"light", Vec3f(kNan, 1, 1), std::nullopt}});
       },
       absl::StatusCode::kInvalidArgument},
      {"CameraNotFinite", camera_change([](Camera& c) { c.position.y = kNan; }),
       absl::StatusCode::kInvalidArgument},
      {"CameraFov", camera_change([](Camera& c) { c.vertical_fov_deg = 180; }),
       absl::StatusCode::kInvalidArgument},
      {"CameraNoPixels", camera_change([](Camera& c) { c.width = 0; }),
       absl::StatusCode::kInvalidArgument},
      {"CameraTooLarge", camera_change([](Camera& c) { c.height = 16385; }),
       absl::StatusCode::kInvalidArgument},
      {"CameraBeyondTheBudget", camera_change([](Camera& c) { c.width = c.height = 16384; }),
       absl::StatusCode::kResourceExhausted},
      {"SettingsNoK", settings_change([](RenderSettings& s) { s.k_nearest = 0; }),
       absl::StatusCode::kInvalidArgument},
      {"SettingsAlphaNotFinite", settings_change([](RenderSettings& s) { s.sppm_alpha = kNan; }),
       absl::StatusCode::kInvalidArgument},
      {"SettingsSizeTooLarge", settings_change([](RenderSettings&) {}, {16385, 16}),
       absl::StatusCode::kInvalidArgument},
      {"SettingsSizeBeyondTheBudget", settings_change([](RenderSettings&) {}, {16384, 16384}),
       absl::StatusCode::kResourceExhausted},
      {"PhotonsBeyondTheBudget",
       settings_change([](RenderSettings& s) { s.photons_per_pass = 20'000'000; }),
       absl::StatusCode::kResourceExhausted},
      {"StructureAndPhotonsBeyondTheBudget", settings_change([](RenderSettings& s) {
         s.structure = StructureKind::kKdSah;
         s.photons_per_pass = 20'000'000;
       }),
       absl::StatusCode::kResourceExhausted},
      {"MediaUnsupported",
       settings_change([](RenderSettings& s) { s.estimator = EstimatorKind::kSppm; }),
       absl::StatusCode::kUnimplemented, true},
  };
  return cases;
}

void PrintTo(const Refusal& r, std::ostream* os) { *os << r.name; }

class Refused : public ::testing::TestWithParam<std::tuple<Refusal, size_t>> {};

TEST_P(Refused, RefusesTheChangeAndKeepsTheImage) {
  const auto& [r, devices] = GetParam();
  TestEngine t = rendered_engine(small_scene(r.fog), devices, kSmallBudget);
  ASSERT_TRUE(t.engine);
  const std::vector<uint32_t> before = image_of(*t.engine);
  ASSERT_TRUE(lit(before));
  expect_refused(t, r.change, r.code, before);
}

INSTANTIATE_TEST_SUITE_P(Changes, Refused,
                         ::testing::Combine(::testing::ValuesIn(refusals()),
                                            ::testing::Values(1, 2)),
                         [](const ::testing::TestParamInfo<std::tuple<Refusal, size_t>>& info) {
                           return std::string(std::get<0>(info.param).name) + "On" +
                                  std::to_string(std::get<1>(info.param)) + "Devices";
                         });

}  // namespace
}  // namespace caustica
