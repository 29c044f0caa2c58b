// Participating media against closed forms: the medium's own sums (transmittance, free flights,
// the phase function), single scattering from a point light seen through fog by both integrators,
// energy balance in a closed, non-absorbing medium, and transmittance on the way to a lit floor.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <vector>

#include "renderer/medium/medium.h"
#include "renderer/parallel/backend.h"
#include "renderer/photon/photon_tracer.h"
#include "renderer/photon/volume_map.h"
#include "renderer/resident/resident_scene.h"
#include "tests/renderer/grid_files.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// A scene resident on the CPU and `count` photons traced in it.
struct CpuTrace {
  std::shared_ptr<Backend> backend;
  ResidentScene resident;
  TracedPhotons photons;

  CpuTrace(const Scene& scene, uint32_t count)
      : backend(make_backend(DeviceKind::kCpu, size_t{1} << 30).value()),
        resident(ResidentScene::upload(*backend, scene)) {
    PhotonTraceSettings trace;
    trace.photon_count = count;
    photons = trace_photons(*backend, resident, trace);
  }
};

DeviceMedium grey_medium(float sigma_a, float sigma_s, float g) {
  DeviceMedium m{};
  m.kind = MediumKind::kHomogeneous;
  m.sigma_s = Vec3f(sigma_s);
  m.sigma_t = Vec3f(sigma_a + sigma_s);
  m.albedo = Vec3f(sigma_a + sigma_s > 0 ? sigma_s / (sigma_a + sigma_s) : 0.0f);
  m.majorant = sigma_a + sigma_s;
  m.g = g;
  return m;
}

TEST(Medium, TransmittanceIsBeerLambert) {
  const DeviceMedium m = grey_medium(0.3f, 0.2f, 0.0f);
  for (float d : {0.0f, 0.5f, 2.0f, 10.0f})
    EXPECT_NEAR(transmittance(m, d).y, std::exp(-0.5 * d), 1e-6);
}

// Free flights with the majorant: the share that crosses a span is its transmittance, and in a
// coloured medium the weights make each channel's expectation its own transmittance.
TEST(Medium, FreeFlightsCrossASpanWithItsTransmittance) {
  DeviceMedium m = grey_medium(0.0f, 1.0f, 0.0f);
  m.sigma_t = Vec3f(1.0f, 0.5f, 0.25f);
  m.sigma_s = m.sigma_t;
  m.albedo = Vec3f(1.0f);
  m.majorant = 1.0f;
  const MediumSpan span{0.5f, 2.5f};
  const int n = 400000;
  Vec3f passed(0.0f), collided_weight(0.0f);
  double collided_distance = 0;
  int collisions = 0;
  for (int i = 0; i < n; ++i) {
    const FreeFlight f = homogeneous_free_flight(m, span, (float(i) + 0.5f) / float(n));
    if (f.collided) {
      EXPECT_GE(f.t, span.t0);
      EXPECT_LT(f.t, span.t1);
      collided_distance += f.t - span.t0;
      collided_weight += f.weight;
      ++collisions;
    } else {
      passed += f.weight;
    }
  }
  for (int c = 0; c < 3; ++c) {
    SCOPED_TRACE(c);
    // Expected weight of escaping: each channel's transmittance over the span's length 2.
    EXPECT_NEAR(passed[c] / n, std::exp(-2.0 * m.sigma_t[c]), 2e-3);
    // Escapes and collisions together hold every photon once per channel.
    EXPECT_NEAR((passed[c] + collided_weight[c]) / n, 1.0, 3e-3);
  }
  // The mean depth of a collision in an exponential truncated at 2.
  const double mean = 1.0 - 2.0 * std::exp(-2.0) / (1.0 - std::exp(-2.0));
  EXPECT_NEAR(collided_distance / collisions, mean, 2e-3);
}

TEST(Medium, ASpanIsTheSceneMediumsPartWithinTheBounds) {
  DeviceMedium fog = grey_medium(0.1f, 0.1f, 0.0f);
  uint32_t inside = 7;
  MediaView media{&fog, &inside, 1, 0, Aabb{Vec3f(-1.0f), Vec3f(1.0f)}};
  // From outside the box along x: it enters at 2 and leaves at 4.
  MediumSpan s = medium_span(media, 0, Vec3f(-3.0f, 0.0f, 0.0f), Vec3f(1.0f, 0.0f, 0.0f), 100.0f);
  EXPECT_FLOAT_EQ(s.t0, 2.0f);
  EXPECT_FLOAT_EQ(s.t1, 4.0f);
  // Cut short by a surface at 3.
  s = medium_span(media, 0, Vec3f(-3.0f, 0.0f, 0.0f), Vec3f(1.0f, 0.0f, 0.0f), 3.0f);
  EXPECT_FLOAT_EQ(s.t1, 3.0f);
  // Missing the box, and in vacuum: nothing.
  EXPECT_EQ(
      medium_span(media, 0, Vec3f(-3.0f, 2.0f, 0.0f), Vec3f(1.0f, 0.0f, 0.0f), 100.0f).length(),
      0.0f);
  EXPECT_EQ(medium_span(media, kVacuum, Vec3f(0.0f), Vec3f(1.0f, 0.0f, 0.0f), 1.0f).length(), 0.0f);
  // Crossing a boundary: in through its front face into what it encloses, out into the scene's.
  EXPECT_EQ(medium_after_crossing(media, 0, Vec3f(0, 0, -1), Vec3f(0, 0, 1)), 7u);
  EXPECT_EQ(medium_after_crossing(media, 0, Vec3f(0, 0, 1), Vec3f(0, 0, 1)), 0u);
}

// The phase function integrates to 1 over the sphere, has mean cosine g, and its sampling follows
// it: the histogram of sampled cosines matches the density's integral over each bin.
TEST(Medium, HenyeyGreensteinIsNormalisedAndSampledByItsDensity) {
  for (float g : {-0.7f, 0.0f, 0.3f, 0.9f}) {
    SCOPED_TRACE(g);
    const int steps = 200000;
    double integral = 0, mean_cos = 0;
    for (int i = 0; i < steps; ++i) {
      const double mu = -1.0 + 2.0 * (i + 0.5) / steps;
      const double p = henyey_greenstein(float(mu), g) * 2.0 * kPi * (2.0 / steps);
      integral += p;
      mean_cos += mu * p;
    }
    EXPECT_NEAR(integral, 1.0, 1e-3);
    EXPECT_NEAR(mean_cos, g, 2e-3);

    const Vec3f travel = normalize(Vec3f(0.3f, -0.5f, 0.8f));
    constexpr int kBins = 16;
    std::vector<double> count(kBins, 0.0);
    const int n = 256 * 1024;
    Sampler s(7, 0, 0);
    double sampled_mean = 0;
    for (int i = 0; i < n; ++i) {
      const Vec3f w = sample_henyey_greenstein(travel, g, s.next_float(), s.next_float());
      ASSERT_NEAR(length(w), 1.0f, 1e-4f);
      const float mu = std::clamp(dot(w, travel), -1.0f, 0.999999f);
      count[size_t((mu + 1.0f) * 0.5f * kBins)] += 1;
      sampled_mean += mu;
    }
    EXPECT_NEAR(sampled_mean / n, g, 5e-3);
    for (int b = 0; b < kBins; ++b) {
      double expected = 0;
      const int sub = 4000;
      for (int i = 0; i < sub; ++i) {
        const double mu = -1.0 + 2.0 * (b + (i + 0.5) / sub) / kBins;
        expected += henyey_greenstein(float(mu), g) * 2.0 * kPi * (2.0 / kBins / sub);
      }
      expected *= n;
      // Five standard deviations of a Poisson count, and a hundredth of the bin for rounding.
      EXPECT_NEAR(count[b], expected, 5.0 * std::sqrt(expected) + 0.01 * expected) << "bin " << b;
    }
  }
}

// A black sphere of radius 3 filled with fog (absorbing 99%, so that light scattered twice is
// under 1% of light scattered once), a point light inside it, and a camera inside looking past
// the light: each pixel's radiance is single scattering alone,
//   L = integral over t of e^(-sigma_t t) sigma_s p I e^(-sigma_t r(t)) / r(t)^2,
// which the test sums finely along each pixel's ray.
struct FogAroundAPointLight {
  float sigma_a = 0.999f, sigma_s = 0.001f, g = 0.4f, intensity = 4000.0f;
  // Outside the camera's view, so that no pixel's rays pass near it: the radiance then varies
  // smoothly across every pixel.
  Vec3f light{1.4f, 0.3f, 0.2f};
  int size = 24;

  // `grid_file`: the fog is a grid medium of that NanoVDB file (in `base_dir`), whose density is 1
  // wherever the rays go.
  Scene scene(const std::string& settings, const std::string& grid_file = "",
              const std::filesystem::path& base_dir = ".") const {
    const std::string type =
        grid_file.empty()
            ? R"("homogeneous")"
            : absl::StrFormat(R"("grid", "file": "%s", "grid": "density")", grid_file);
    absl::StatusOr<Scene> parsed = parse_scene(
        absl::StrFormat(R"({
      "camera": {"position": [0, 0, -2], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40,
                 "width": %d, "height": %d},
      "settings": %s,
      "materials": {"black": {"type": "diffuse", "albedo": [0, 0, 0]}},
      "media": {"fog": {"type": %s, "absorption": [%f, %f, %f],
                        "scattering": [%f, %f, %f], "g": %f}},
      "medium": "fog",
      "lights": [{"type": "point", "position": [%f, %f, %f], "intensity": [%f, %f, %f]}],
      "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 3, "rings": 96,
                  "segments": 192, "material": "black"}]
    })",
                        size, size, settings, type, sigma_a, sigma_a, sigma_a, sigma_s, sigma_s,
                        sigma_s, g, light.x, light.y, light.z, intensity, intensity, intensity),
        base_dir, "fog.json");
    EXPECT_TRUE(parsed.ok()) << parsed.status();
    return parsed.ok() ? *parsed : Scene{};
  }

  // Single scattering along the rays through 2 x 2 points of pixel (x, y) to the sphere.
  double expected(const Scene& s, int x, int y) const {
    double sum = 0;
    for (float dy : {0.25f, 0.75f})
      for (float dx : {0.25f, 0.75f}) sum += expected_along(s, x + dx, y + dy);
    return sum / 4;
  }

  double expected_along(const Scene& s, float x, float y) const {
    const PinholeCamera cam = PinholeCamera::from(s.camera);
    const Ray r = cam.ray_through(x, y);
    // |o + t d| = 3.
    const double b = dot(r.origin, r.direction), c = length_squared(r.origin) - 9.0;
    const double t_wall = -b + std::sqrt(b * b - c);
    const double sigma_t = sigma_a + sigma_s;
    const int steps = 4000;
    double sum = 0;
    for (int i = 0; i < steps; ++i) {
      const double t = (i + 0.5) * t_wall / steps;
      const Vec3f p = r.origin + r.direction * float(t);
      const Vec3f to_light = light - p;
      const double dist = length(to_light);
      // Light travels from the light to p, then back along the ray.
      const double cos_theta = dot(to_light, r.direction) / dist;
      sum += std::exp(-sigma_t * (t + dist)) * sigma_s * henyey_greenstein(float(cos_theta), g) *
             intensity / (dist * dist);
    }
    return sum * t_wall / steps;
  }

  // The mean over blocks of `block` x `block` pixels of the rendered and expected green radiance;
  // the largest relative difference of any block.
  double worst_block_error(const Scene& s, std::span<const float> image, int block) const {
    double worst = 0;
    for (int by = 0; by < size; by += block) {
      for (int bx = 0; bx < size; bx += block) {
        double got = 0, want = 0;
        for (int y = by; y < by + block; ++y) {
          for (int x = bx; x < bx + block; ++x) {
            got += image[4 * (y * size + x) + 1];
            want += expected(s, x, y);
          }
        }
        worst = std::max(worst, std::fabs(got - want) / want);
      }
    }
    return worst;
  }
};

TEST(Media, PathTracerMatchesSingleScatteringInFog) {
  const FogAroundAPointLight fog;
  const Scene s = fog.scene(R"({"integrator": "path"})");
  auto engine = engine_with(s);
  ASSERT_TRUE(engine->render(1024).ok());
  EXPECT_LT(fog.worst_block_error(s, engine->image_linear(), 4), 0.03);
}

TEST(Media, BeamRadianceEstimateMatchesSingleScatteringInFog) {
  const FogAroundAPointLight fog;
  // The knn estimator's bandwidths, and those of the collisions' photon differentials.
  for (const char* settings :
       {R"({"photons": 200000})", R"({"photons": 200000, "estimator": "vkde"})"}) {
    SCOPED_TRACE(settings);
    const Scene s = fog.scene(settings);
    auto engine = engine_with(s);
    ASSERT_TRUE(engine->render(16).ok());
    // A pass's estimate along one ray scatters by about 6% here (its rays gather 100 to 200
    // collisions where most of their light comes from), and neighbouring pixels share
    // collisions: blocks of 8 x 8 pixels over 16 passes leave about 2%.
    EXPECT_LT(fog.worst_block_error(s, engine->image_linear(), 8), 0.06);
  }
}

// Grid media, their files in a directory of each test's own.
class GridMedia : public ::testing::Test {
 protected:
  // Density 1 over the cube [-3.25, 3.25]^3, around FogAroundAPointLight's sphere.
  std::string write_unit_fog() {
    test_grids::write_grid(dir_ / "fog.nvdb",
                           test_grids::density_grid(27, 0.25, nanovdb::Vec3d(-3.25),
                                                    [](int, int, int) { return 1.0f; }));
    return "fog.nvdb";
  }

  test_grids::ScratchDirectory scratch_;
  const std::filesystem::path& dir_ = scratch_.path();
};

// A density ramp along x, 0.1 + 0.4 x, which trilinear samples reproduce exactly: the marched
// transmittance matches the closed form, and delta-tracked flights through it escape with each
// channel's transmittance and collide with the rest.
TEST_F(GridMedia, TransmittanceAndFreeFlightsFollowTheDensity) {
  const auto handle = test_grids::density_grid(32, 0.125, nanovdb::Vec3d(0.0),
                                               [](int i, int, int) { return 0.1f + 0.05f * i; });
  Medium ramp;
  ramp.type = MediumType::kGrid;
  ramp.absorption = Vec3f(0.5f, 0.25f, 0.0f);
  ramp.scattering = Vec3f(0.5f, 0.25f, 0.25f);
  ramp.grid = test_grids::grid_bytes(handle);
  // On the CPU, the grid's host buffer is where kernels read it.
  const DeviceMedium m = to_device_medium(ramp, ramp.grid->data());
  EXPECT_FLOAT_EQ(m.majorant, 1.0f * (0.1f + 0.05f * 31));
  const Vec3f origin(0.0f, 2.0f, 2.0f), direction(1.0f, 0.0f, 0.0f);
  const MediumSpan span = clip_span(MediumSpan{0.5f, 3.0f}, m.grid.bounds, origin, direction);
  ASSERT_FLOAT_EQ(span.t0, 0.5f);
  ASSERT_FLOAT_EQ(span.t1, 3.0f);
  auto integral = [](double a, double b) { return 0.1 * (b - a) + 0.2 * (b * b - a * a); };
  const Vec3f tr = span_transmittance(m, origin, direction, span);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(tr[c], std::exp(-m.sigma_t[c] * integral(0.5, 3.0)), 1e-5) << c;
  // The beam estimate's optical depths: exact at knots, and between them off by at most the
  // linear interpolation's error for this quadratic, 0.4 (2.5 / 32)^2 / 4.
  const OpticalDepth depth(m.grid, origin, direction, span);
  for (float t : {0.5f, 0.578125f, 1.90625f, 3.0f})
    EXPECT_NEAR(depth.at(t), integral(0.5, t), 2e-5);
  for (float t : {0.77f, 1.21f}) EXPECT_NEAR(depth.at(t), integral(0.5, t), 6.2e-4) << t;

  Sampler sampler(7, 0, 0);
  const int n = 200000;
  Vec3f escaped(0.0f), collided(0.0f);
  for (int i = 0; i < n; ++i) {
    const FreeFlight f =
        sample_free_flight(m, origin, direction, span, [&] { return sampler.next_float(); });
    if (f.collided) {
      EXPECT_GE(f.t, span.t0);
      EXPECT_LT(f.t, span.t1);
      collided += f.weight;
    } else {
      escaped += f.weight;
    }
  }
  for (int c = 0; c < 3; ++c) {
    SCOPED_TRACE(c);
    const double expected = std::exp(-m.sigma_t[c] * integral(0.5, 3.0));
    EXPECT_NEAR(escaped[c] / n, expected, 5e-3);
    EXPECT_NEAR(collided[c] / n, 1.0 - expected, 5e-3);
  }
}

// Photon differentials through a grid: a point light in the density ramp 0.1 + 0.4 x, whose
// first flights stop at distance r with density n sigma rho(x) tau / (4 pi r^2), tau the
// transmittance exp(-sigma r rho(midpoint)) of the ramp (linear along the way): the collisions'
// footprint volumes are its inverse.
TEST_F(GridMedia, CollisionFootprintsAreTheInverseOfTheirDensity) {
  test_grids::write_grid(dir_ / "ramp.nvdb", test_grids::density_grid(
                                                 32, 0.125, nanovdb::Vec3d(0.0),
                                                 [](int i, int, int) { return 0.1f + 0.05f * i; }));
  const float sigma = 0.5f;
  const Vec3f light(2.0f, 2.0f, 2.0f);
  const Scene scene = parse_or_die(absl::StrFormat(R"({
      "camera": {"position": [2, 2, 1], "look_at": [2, 2, 2], "fov": 60, "width": 8, "height": 8},
      "materials": {"black": {"type": "diffuse", "albedo": [0, 0, 0]}},
      "media": {"ramp": {"type": "grid", "file": "ramp.nvdb", "grid": "density",
                         "absorption": [0, 0, 0], "scattering": [%f, %f, %f]}},
      "medium": "ramp",
      "lights": [{"type": "point", "position": [%f, %f, %f], "intensity": [1, 1, 1]}],
      "shapes": [{"type": "sphere", "center": [2, 2, 2], "radius": 1.5, "material": "black"}]
    })",
                                                   sigma, sigma, sigma, light.x, light.y, light.z),
                                   dir_);
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(1) << 30);
  const ResidentScene resident = ResidentScene::upload(*backend, scene);
  PhotonTraceSettings trace;
  trace.photon_count = 20000;
  trace.max_bounces = 1;  // first flights only
  trace.differentials = true;
  const TracedPhotons traced = trace_photons(*backend, resident, trace);
  const std::vector<Photon> collisions = traced.volume.download();
  const std::vector<float> volumes = traced.volume_footprints.download();
  ASSERT_EQ(collisions.size(), volumes.size());
  ASSERT_GT(collisions.size(), 5000u);
  auto density = [](Vec3f p) { return 0.1 + 0.4 * p.x; };
  for (size_t i = 0; i < collisions.size(); ++i) {
    const Vec3f x = collisions[i].position;
    const double r = length(x - light);
    if (r < 0.01) continue;  // where float positions leave too few digits of r
    const double tau = std::exp(-sigma * r * density((x + light) * 0.5f));
    const double expected = 4.0 * kPi * r * r / (trace.photon_count * sigma * density(x) * tau);
    EXPECT_NEAR(volumes[i] / expected, 1.0, 2e-3) << "collision " << i << " at distance " << r;
  }
}

TEST_F(GridMedia, PathTracerMatchesSingleScatteringInAGrid) {
  const FogAroundAPointLight fog;
  const Scene s = fog.scene(R"({"integrator": "path"})", write_unit_fog(), dir_);
  ASSERT_EQ(s.media.at(0).type, MediumType::kGrid);
  auto engine = engine_with(s);
  ASSERT_TRUE(engine->render(1024).ok());
  EXPECT_LT(fog.worst_block_error(s, engine->image_linear(), 4), 0.03);
}

TEST_F(GridMedia, BeamRadianceEstimateMatchesSingleScatteringInAGrid) {
  const FogAroundAPointLight fog;
  const std::string file = write_unit_fog();
  for (const char* settings :
       {R"({"photons": 200000})", R"({"photons": 200000, "estimator": "vkde"})"}) {
    SCOPED_TRACE(settings);
    const Scene s = fog.scene(settings, file, dir_);
    auto engine = engine_with(s);
    ASSERT_TRUE(engine->render(16).ok());
    EXPECT_LT(fog.worst_block_error(s, engine->image_linear(), 8), 0.06);
  }
}

// A point light at the centre of a closed black sphere of fog that absorbs nothing: every photon
// ends on the wall, reaching it directly with probability e^(-sigma R) (left to shadow rays) or
// after scattering (stored in the global map), so the global map holds the rest of the power.
TEST(Media, ClosedNonAbsorbingFogDeliversAllPowerToTheWalls) {
  const float sigma = 0.7f, radius = 1.5f, intensity = 2.0f;
  const Scene scene =
      parse_or_die(absl::StrFormat(R"({
      "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "fov": 60, "width": 8, "height": 8},
      "materials": {"black": {"type": "diffuse", "albedo": [0, 0, 0]}},
      "media": {"fog": {"type": "homogeneous", "absorption": [0, 0, 0],
                        "scattering": [%f, %f, %f], "g": 0.5}},
      "medium": "fog",
      "lights": [{"type": "point", "position": [0, 0, 0], "intensity": [%f, %f, %f]}],
      "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": %f, "rings": 128,
                  "segments": 256, "material": "black"}]
    })",
                                   sigma, sigma, sigma, intensity, intensity, intensity, radius));
  const CpuTrace run(scene, 200000);
  const TracedPhotons& traced = run.photons;
  EXPECT_EQ(traced.caustic.size(), 0u);  // nothing specular
  double wall = 0, scattered = 0;
  for (const Photon& p : traced.global.download()) {
    wall += p.power.y;
    EXPECT_NEAR(length(p.position), radius, 2e-3f);
  }
  for (const Photon& p : traced.volume.download()) {
    scattered += p.power.y;
    EXPECT_LT(length(p.position), radius);
  }
  const double power = 4.0 * kPi * intensity;
  EXPECT_NEAR(wall / power, 1.0 - std::exp(-sigma * radius), 5e-3);
  // Each collision scatters all it carries: at least the power of the photons that collide.
  EXPECT_GT(scattered / power, 1.0 - std::exp(-sigma * radius));
}

// A lit floor in absorbing fog inside a black sphere: direct light, attenuated on its way from
// the light and on its way to the camera, and nothing else (the sphere returns nothing).
struct FloorInInk {
  float sigma = 0.4f, rho = 0.6f, intensity = 3.0f;
  Vec3f light{0.3f, 1.0f, 0.2f}, eye{0.0f, 1.5f, -1.5f};
  int size = 32;

  Scene scene(const std::string& settings) const {
    return parse_or_die(absl::StrFormat(R"({
      "camera": {"position": [%f, %f, %f], "look_at": [0, 0, 0], "fov": 40,
                 "width": %d, "height": %d},
      "settings": %s,
      "materials": {"black": {"type": "diffuse", "albedo": [0, 0, 0]},
                    "floor": {"type": "diffuse", "albedo": [%f, %f, %f]}},
      "media": {"ink": {"type": "homogeneous", "absorption": [%f, %f, %f],
                        "scattering": [0, 0, 0]}},
      "medium": "ink",
      "lights": [{"type": "point", "position": [%f, %f, %f], "intensity": [%f, %f, %f]}],
      "shapes": [{"type": "quad", "material": "floor",
                  "vertices": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]},
                 {"type": "sphere", "center": [0, 0, 0], "radius": 4, "material": "black"}]
    })",
                                        eye.x, eye.y, eye.z, size, size, settings, rho, rho, rho,
                                        sigma, sigma, sigma, light.x, light.y, light.z, intensity,
                                        intensity, intensity));
  }

  // The mean over blocks of 4 x 4 pixels that see only the floor, away from its edges, of the
  // rendered and expected green radiance: the largest relative difference; `checked` counts them.
  double worst_block_error(const Scene& s, std::span<const float> image, int& checked) const {
    const PinholeCamera cam = PinholeCamera::from(s.camera);
    double worst = 0;
    checked = 0;
    for (int by = 0; by < size; by += 4) {
      for (int bx = 0; bx < size; bx += 4) {
        double got = 0, want = 0;
        bool on_floor = true;
        for (int y = by; y < by + 4; ++y) {
          for (int x = bx; x < bx + 4; ++x) {
            const Ray r = cam.ray_through(x + 0.5f, y + 0.5f);
            const float t = -r.origin.y / r.direction.y;
            const Vec3f p = r.origin + r.direction * t;
            on_floor = on_floor && t > 0 && std::fabs(p.x) < 0.9f && std::fabs(p.z) < 0.9f;
            const Vec3f d = light - p;
            const float dist = length(d);
            want += rho / kPi * intensity * (d.y / dist) / (dist * dist) *
                    std::exp(-sigma * (dist + t));
            got += image[4 * (y * size + x) + 1];
          }
        }
        if (!on_floor) continue;
        worst = std::max(worst, std::fabs(got - want) / want);
        ++checked;
      }
    }
    return worst;
  }
};

TEST(Media, TransmittanceAttenuatesTheWayToAndFromALitFloor) {
  const FloorInInk ink;
  for (const char* settings :
       {R"({"photons": 20000})", R"({"photons": 20000, "estimator": "vkde"})",
        R"({"integrator": "path"})"}) {
    SCOPED_TRACE(settings);
    const Scene s = ink.scene(settings);
    auto engine = engine_with(s);
    const bool path = std::string(settings).find("path") != std::string::npos;
    ASSERT_TRUE(engine->render(path ? 1024 : 4).ok());
    int checked = 0;
    EXPECT_LT(ink.worst_block_error(s, engine->image_linear(), checked), path ? 0.03 : 0.01);
    EXPECT_GE(checked, 8);
  }
}

// Estimators that do not render media refuse a scene with them, and the engine keeps what it had.
TEST(Media, EstimatorsThatDoNotRenderMediaRefuseThem) {
  const FloorInInk ink;
  auto engine = engine_with(ink.scene("{}"));
  RenderSettings sppm = engine->scene().settings;
  sppm.estimator = EstimatorKind::kSppm;
  const absl::StatusOr<RebuildReport> refused = engine->set_settings(sppm);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kUnimplemented);
  EXPECT_THAT(std::string(refused.status().message()),
              testing::HasSubstr("media: the sppm estimator does not render participating media"));
  EXPECT_EQ(engine->scene().settings.estimator, EstimatorKind::kKnn);
  EXPECT_TRUE(engine->render(1).ok());
  const absl::StatusOr<RebuildReport> loaded =
      Engine::create({}).value()->load(ink.scene(R"({"estimator": "sppm"})"));
  EXPECT_EQ(loaded.status().code(), absl::StatusCode::kUnimplemented);
  RenderSettings gathered = engine->scene().settings;
  gathered.final_gather = true;
  EXPECT_THAT(std::string(engine->set_settings(gathered).status().message()),
              testing::HasSubstr("final gathering does not trace through participating media"));
}

// The beam query through the tree finds what a loop over every collision finds, along rays in
// every direction, near and far from the light.
TEST(VolumeMap, BeamQueryFindsWhatBruteForceFinds) {
  const FogAroundAPointLight fog;
  const CpuTrace run(fog.scene("{}"), 50000);
  const ResidentScene& resident = run.resident;
  const VolumeMap map = build_volume_map(*run.backend, run.photons.volume, 8, kVolumeNearest, 0.5f);
  ASSERT_GT(map.size(), 10000u);
  const VolumeMapView view = map.view();
  const std::vector<Photon> photons = map.points.download();
  const std::vector<float> bandwidth = map.bandwidth.download();
  const ResidentSceneView scene = resident.view();
  const DeviceMedium& fog_medium = scene.media.media[0];
  Sampler rng(3, 0, 0);
  for (int r = 0; r < 64; ++r) {
    const Vec3f origin =
        (r % 2 == 0 ? fog.light : Vec3f(0.0f)) +
        (Vec3f(rng.next_float(), rng.next_float(), rng.next_float()) - Vec3f(0.5f));
    const Vec3f direction = sample_uniform_sphere(rng.next_float(), rng.next_float());
    const MediumSpan span = medium_span(scene.media, 0, origin, direction, 2.5f);
    const Vec3f found = beam_radiance(view, fog_medium, origin, direction, span);
    Vec3f expected(0.0f);
    for (size_t i = 0; i < photons.size(); ++i) {
      const Vec3f v = photons[i].position - origin;
      const float t = dot(v, direction);
      const float h2 = bandwidth[i] * bandwidth[i];
      const float d2 = length_squared(v) - t * t;
      if (t < span.t0 || t > span.t1 || !(d2 < h2)) continue;
      expected += photons[i].power * transmittance(fog_medium, t - span.t0) *
                  (2.0f * kInvPi * (1.0f - d2 / h2) / h2 *
                   henyey_greenstein(dot(photons[i].incoming, direction), fog_medium.g));
    }
    EXPECT_NEAR(found.y, expected.y, 1e-3f * expected.y + 1e-9f) << "ray " << r;
  }
}

}  // namespace
}  // namespace caustica
