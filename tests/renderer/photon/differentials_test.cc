// Photon differentials (photon/differentials.h) against finite differences of the functions they
// differentiate, and their footprints against the photon densities they stand for.
#include "renderer/photon/differentials.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>

#include "absl/strings/str_format.h"
#include "renderer/material/fresnel.h"
#include "renderer/medium/medium.h"
#include "renderer/photon/photon_tracer.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

constexpr double kStep = 1e-3;

void expect_near(Vec3f got, Vec3f expected, double tolerance, const char* what) {
  EXPECT_NEAR(got.x, expected.x, tolerance) << what;
  EXPECT_NEAR(got.y, expected.y, tolerance) << what;
  EXPECT_NEAR(got.z, expected.z, tolerance) << what;
}

// The central difference of f at 0.
Vec3f derivative(const std::function<Vec3f(float)>& f) {
  return (f(float(kStep)) - f(float(-kStep))) / float(2 * kStep);
}

// A family of rays z(p) = z0 + p a, w(p) = normalize(w0 + p b): its differentials at p = 0.
struct RayFamily {
  Vec3f z0, a, w0, b;
  Vec3f origin(float p) const { return z0 + a * p; }
  Vec3f direction(float p) const { return normalize(w0 + b * p); }
  PhotonDifferentials differentials() const {
    const Vec3f w = normalize(w0);
    const Vec3f dw = (b - w * dot(w, b)) / length(w0);
    return {a, Vec3f(0.0f), dw, Vec3f(0.0f)};
  }
};

// The hit of ray (z, w) with the plane through `q` of normal `n`.
Vec3f plane_hit(Vec3f z, Vec3f w, Vec3f q, Vec3f n) { return z + w * (dot(q - z, n) / dot(w, n)); }

// The hit of ray (z, w) with the sphere of `radius` at the origin, from outside.
Vec3f sphere_hit(Vec3f z, Vec3f w, float radius) {
  const float b = dot(z, w), c = dot(z, z) - radius * radius;
  return z + w * (-b - std::sqrt(b * b - c));
}

TEST(PhotonDifferentials, TransferFollowsTheHitPointOnAPlane) {
  const RayFamily ray{Vec3f(0.1f, 0.2f, 2.0f), Vec3f(0.3f, -0.2f, 0.1f), Vec3f(0.2f, -0.1f, -1.0f),
                      Vec3f(0.4f, 0.3f, -0.2f)};
  const Vec3f q(0.0f, 0.0f, -1.0f), n = normalize(Vec3f(0.1f, 0.2f, 1.0f));
  PhotonDifferentials d = ray.differentials();
  const Vec3f w = ray.direction(0);
  const Vec3f hit = plane_hit(ray.origin(0), w, q, n);
  transfer(d, w, length(hit - ray.origin(0)), n);
  const Vec3f expected =
      derivative([&](float p) { return plane_hit(ray.origin(p), ray.direction(p), q, n); });
  expect_near(d.dz1, expected, 1e-3, "dz");
}

// A sphere's normal is z / R, so its derivative along the hit point's is dz / R.
TEST(PhotonDifferentials, ReflectionOffACurvedMirrorFollowsTheReflectedDirection) {
  const float radius = 1.5f;
  const RayFamily ray{Vec3f(0.4f, 0.3f, 4.0f), Vec3f(0.2f, 0.1f, 0.0f), Vec3f(-0.05f, 0.02f, -1.0f),
                      Vec3f(0.1f, -0.2f, 0.0f)};
  auto reflected = [&](float p) {
    const Vec3f hit = sphere_hit(ray.origin(p), ray.direction(p), radius);
    return reflect(ray.direction(p), hit / radius);
  };
  PhotonDifferentials d = ray.differentials();
  const Vec3f w = ray.direction(0);
  const Vec3f hit = sphere_hit(ray.origin(0), w, radius);
  const Vec3f n = hit / radius;
  transfer(d, w, length(hit - ray.origin(0)), n);
  reflect_differentials(d, w, n, d.dz1 / radius, d.dz2 / radius);
  expect_near(d.dw1, derivative(reflected), 2e-3, "dw");
}

TEST(PhotonDifferentials, RefractionThroughACurvedSurfaceFollowsTheRefractedDirection) {
  const float radius = 1.5f;
  const RayFamily ray{Vec3f(0.4f, 0.3f, 4.0f), Vec3f(0.2f, 0.1f, 0.0f), Vec3f(-0.05f, 0.02f, -1.0f),
                      Vec3f(0.1f, -0.2f, 0.0f)};
  for (const float eta : {1.5f, 1.0f / 1.33f}) {
    auto refracted = [&](float p) {
      const Vec3f hit = sphere_hit(ray.origin(p), ray.direction(p), radius);
      Vec3f t;
      EXPECT_TRUE(refract(ray.direction(p), hit / radius, eta, t));
      return t;
    };
    PhotonDifferentials d = ray.differentials();
    const Vec3f w = ray.direction(0);
    const Vec3f hit = sphere_hit(ray.origin(0), w, radius);
    const Vec3f n = hit / radius;
    transfer(d, w, length(hit - ray.origin(0)), n);
    refract_differentials(d, w, n, eta, refracted(0), d.dz1 / radius, d.dz2 / radius);
    expect_near(d.dw1, derivative(refracted), 2e-3, "dw");
  }
}

TEST(PhotonDifferentials, ShadingNormalDerivativeFollowsTheInterpolatedNormal) {
  const Vec3f v0(0, 0, 0), v1(2, 0.2f, 0), v2(0.3f, 1.8f, 0.1f);
  const Vec3f n0 = normalize(Vec3f(0.1f, 0.2f, 1)), n1 = normalize(Vec3f(-0.3f, 0.1f, 1)),
              n2 = normalize(Vec3f(0.2f, -0.4f, 1));
  const Vec3f e1 = v1 - v0, e2 = v2 - v0;
  // A direction in the triangle's plane, and the barycentrics along it.
  const Vec3f dz = e1 * 0.3f + e2 * -0.5f;
  const float u = 0.25f, v = 0.4f;
  auto normal_at = [&](float p) {
    // dz = e1 du + e2 dv with du = 0.3, dv = -0.5 per unit p.
    const float up = u + 0.3f * p, vp = v - 0.5f * p;
    return normalize(n0 + (n1 - n0) * up + (n2 - n0) * vp);
  };
  Vec3f dn1, dn2;
  shading_normal_differentials(n0, n1, n2, n0 + (n1 - n0) * u + (n2 - n0) * v, e1, e2, dz,
                               Vec3f(0.0f), dn1, dn2);
  expect_near(dn1, derivative(normal_at), 1e-3, "dn");
  expect_near(dn2, Vec3f(0.0f), 1e-7, "dn along nothing");
}

// Emission differentials against the derivative of the spherical parametrisation they scale: along
// p1 (inclination) the direction turns by a unit vector times the scale, along p2 by sin p1 times
// it, divided by sin p1 by the scaling.
TEST(PhotonDifferentials, EmissionFromASpotIsTheScaledSphericalDerivative) {
  const Vec3f axis = normalize(Vec3f(0.3f, -1.0f, 0.2f));
  const Frame frame = Frame::from_normal(axis);
  const float cos_max = std::cos(0.7f), p1 = 0.4f, p2 = 1.1f;
  auto direction = [&](float a, float b) {
    return frame.to_world(Vec3f(std::cos(b) * std::sin(a), std::sin(b) * std::sin(a), std::cos(a)));
  };
  const PhotonDifferentials d = emitted_from_point(direction(p1, p2), axis, cos_max);
  const float scale = std::sqrt(0.5f * (1.0f - cos_max));
  expect_near(d.dw1, derivative([&](float p) { return direction(p1 + p, p2); }) * scale, 1e-3,
              "dw1");
  expect_near(d.dw2,
              derivative([&](float p) { return direction(p1, p2 + p); }) * (scale / std::sin(p1)),
              1e-3, "dw2");
  expect_near(d.dz1, Vec3f(0.0f), 0.0, "dz1");
}

// What the footprints are for: the area each photon stands for where it lands, the inverse of the
// photons' density there. Photons from a point light hit a plane; the ones in a disk, counted,
// times their mean footprint, cover the disk.
TEST(PhotonDifferentials, PointLightFootprintsCoverThePlaneTheyLandOn) {
  const int n = 400000;
  const float h = 2.0f;
  const Vec3f plane_normal(0, 0, 1), light(0, 0, h);
  for (const float tilt : {0.0f, 0.8f}) {  // the disk straight below, and off to the side
    const Vec3f centre(h * std::tan(tilt), 0.0f, 0.0f);
    const float disk_radius = 0.5f;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    int inside = 0;
    double area_sum = 0;
    for (int i = 0; i < n; ++i) {
      const Vec3f w = sample_uniform_sphere(uniform(rng), uniform(rng));
      if (w.z >= 0.0f) continue;
      PhotonDifferentials d = emitted_from_point(w, Vec3f(0, 0, 1), -1.0f);
      const float t = -h / w.z;
      const Vec3f hit = light + w * t;
      if (length(hit - centre) > disk_radius) continue;
      transfer(d, w, t, plane_normal);
      ++inside;
      area_sum += footprint_area(d, float(n));
    }
    ASSERT_GT(inside, 1000);
    const double covered = area_sum / (kPi * disk_radius * disk_radius);
    EXPECT_NEAR(covered, 1.0, 0.05) << "tilt " << tilt;
  }
}

// The same for an area light (a unit square) treated as a diffuse surface re-emitting with the
// virtual offset: far from the light, where it looks like a point, its photons' footprints cover
// the plane as they should; nearer, the offset's spread shows as (1 + t_v / h)^2.
TEST(PhotonDifferentials, AreaLightFootprintsCoverThePlaneTheyLandOn) {
  const int n = 400000;
  const float side = 1.0f, area = side * side;
  const float offset = area_light_offset(area, 1.0f);
  const Vec3f down(0, 0, -1);
  for (const float h : {4.0f, 12.0f}) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    const float disk_radius = 0.1f * h;
    int inside = 0;
    double area_sum = 0;
    for (int i = 0; i < n; ++i) {
      const Vec3f origin((uniform(rng) - 0.5f) * side, (uniform(rng) - 0.5f) * side, h);
      const Vec3f local = sample_cosine_hemisphere(uniform(rng), uniform(rng));
      const Frame frame = Frame::from_normal(down);
      const Vec3f w = frame.to_world(local);
      PhotonDifferentials d = reemitted_diffusely(w, down, offset);
      const float t = -h / w.z;
      const Vec3f hit = origin + w * t;
      if (length(Vec3f(hit.x, hit.y, 0.0f)) > disk_radius) continue;
      transfer(d, w, t, Vec3f(0, 0, 1));
      ++inside;
      area_sum += footprint_area(d, float(n));
    }
    ASSERT_GT(inside, 1000);
    const double covered = area_sum / (kPi * disk_radius * disk_radius);
    const double spread = (1.0 + offset / h) * (1.0 + offset / h);
    EXPECT_NEAR(covered / spread, 1.0, 0.05) << "height " << h;
  }
}

// Re-emission keeps the footprint's area in expectation: A'(p1') = t_v^2 pi / (n cos p1'), whose
// mean over cosine-distributed directions is t_v^2 2 pi / n = A.
TEST(PhotonDifferentials, DiffuseReemissionKeepsTheFootprintInExpectation) {
  const float n = 1e5f;
  PhotonDifferentials arriving{Vec3f(0.02f, 0.0f, 0.0f), Vec3f(0.005f, 0.03f, 0.0f), Vec3f(0.0f),
                               Vec3f(0.0f)};
  const double before = footprint_area(arriving, n);
  const float offset = reemission_offset(arriving);
  const Vec3f normal(0, 0, 1);
  // The mean over p1' by quadrature (the estimator's variance is infinite at grazing angles).
  double mean = 0;
  const int steps = 20000;
  for (int i = 0; i < steps; ++i) {
    const double p1 = (i + 0.5) * (kPi / 2) / steps;
    const Vec3f w(float(std::sin(p1)) * 0.6f, float(std::sin(p1)) * 0.8f, float(std::cos(p1)));
    const double a = footprint_area(reemitted_diffusely(w, normal, offset), n);
    EXPECT_NEAR(a, offset * offset * kPi / (n * std::cos(p1)), 1e-3 * a);
    mean += a * 2 * std::cos(p1) * std::sin(p1) * (kPi / 2) / steps;  // pdf 2 cos sin
  }
  EXPECT_NEAR(mean / before, 1.0, 1e-3);
}

// Scattering in a medium re-emits like a point light whose directions follow the phase function:
// with g = 0 exactly a point light's differentials, and for any g the footprint volume after a
// zero-length step, (4 pi / n) t_v^2 / (sigma 4 pi pdf), keeps in expectation over the phase
// function the volume the collision had, grown by the albedo's roulette (sec. 7.2.2).
TEST(PhotonDifferentials, ScatteringKeepsTheFootprintVolumeInExpectation) {
  const Vec3f travel = normalize(Vec3f(0.2f, -0.5f, 1.0f));
  const Vec3f w = normalize(Vec3f(-0.7f, 0.1f, 0.3f));
  const PhotonDifferentials iso = scattered_in_medium(w, travel, 0.25f * kInvPi, 0.0f);
  const PhotonDifferentials point = emitted_from_point(w, travel, -1.0f);
  expect_near(iso.dw1, point.dw1, 1e-6, "dw1");
  expect_near(iso.dw2, point.dw2, 1e-6, "dw2");

  const float n = 1e5f, sigma = 0.8f, tau = 0.3f, survive = 0.6f;
  const PhotonDifferentials arriving{Vec3f(0.02f, 0.0f, 0.01f), Vec3f(0.005f, 0.03f, 0.0f),
                                     Vec3f(0.0f), Vec3f(0.0f)};
  const double before = footprint_volume(arriving, travel, sigma * tau, n);
  const float offset = scattering_offset(arriving, travel, tau, survive);
  for (const float g : {0.0f, 0.6f, -0.4f}) {
    SCOPED_TRACE(g);
    // The mean over the phase function by quadrature over cos theta (the volume does not depend
    // on the azimuth).
    const Frame frame = Frame::from_normal(travel);
    double mean = 0;
    const int steps = 20000;
    for (int i = 0; i < steps; ++i) {
      const double cos_theta = -1.0 + (i + 0.5) * 2.0 / steps;
      const double sin_theta = std::sqrt(1.0 - cos_theta * cos_theta);
      const Vec3f out =
          frame.to_world(Vec3f(float(0.6 * sin_theta), float(0.8 * sin_theta), float(cos_theta)));
      const float pdf = henyey_greenstein(dot(travel, out), g);
      const PhotonDifferentials d = scattered_in_medium(out, travel, pdf, offset);
      // The photon steps zero far: dz3 = w / sigma (eq. 7.24), as if the flight density were
      // sigma, its survival 1.
      const double volume = footprint_volume(d, out, sigma, n);
      EXPECT_NEAR(volume, 4.0 * kPi / n * offset * offset / (sigma * 4.0 * kPi * pdf),
                  1e-3 * volume);
      mean += volume * pdf * 2.0 * kPi * 2.0 / steps;  // pdf per steradian, d omega = 2 pi dcos
    }
    EXPECT_NEAR(mean * survive / before, 1.0, 2e-3);
  }
}

// Propagation to a collision moves the position differentials along the direction's, with no
// surface to turn them: a point light's photons stopped at distance t span t dw.
TEST(PhotonDifferentials, PropagationToACollisionFollowsTheDirections) {
  const RayFamily family{Vec3f(0.1f, 0.2f, 0.0f), Vec3f(0.3f, 0.0f, 0.1f), Vec3f(0.2f, -0.1f, 1.0f),
                         Vec3f(0.0f, 0.5f, 0.2f)};
  PhotonDifferentials d = family.differentials();
  const float t = 1.7f;
  propagate(d, t);
  expect_near(d.dz1,
              derivative([&](float p) { return family.origin(p) + family.direction(p) * t; }), 1e-3,
              "dz1");
}

TEST(PhotonDifferentials, RouletteSurvivorsSpreadByTheInverseSquareRoot) {
  PhotonDifferentials d{Vec3f(1, 0, 0), Vec3f(0, 2, 0), Vec3f(0, 0, 3), Vec3f(4, 0, 0)};
  const float before = footprint_area(d, 100.0f);
  survived_roulette(d, 0.25f);
  EXPECT_FLOAT_EQ(footprint_area(d, 100.0f), before * 4.0f);
  EXPECT_FLOAT_EQ(d.dw1.z, 6.0f);
}

}  // namespace
}  // namespace caustica

namespace caustica {
namespace {

// A point light above a flat mirror under a diffuse ceiling, all in grey fog of extinction
// `sigma` (none at 0), traced with differentials.
struct MirrorUnderCeiling {
  float sigma = 0.0f;
  Vec3f light{0.3f, -0.2f, 1.0f};
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(1) << 30);
  std::optional<ResidentScene> resident;

  explicit MirrorUnderCeiling(float fog) : sigma(fog) {
    const std::string media = fog > 0.0f
                                  ? absl::StrFormat(R"("media": {"fog": {"type": "homogeneous",
                     "absorption": [0, 0, 0], "scattering": [%f, %f, %f]}}, "medium": "fog",)",
                                                    fog, fog, fog)
                                  : "";
    absl::StatusOr<Scene> scene = parse_scene(absl::StrFormat(R"({
      "camera": {"position": [0, 0, 1.5], "look_at": [0, 0, 0], "fov": 60, "width": 8,
                 "height": 8},
      "materials": {"mirror": {"type": "mirror", "reflectance": [1, 1, 1]},
                    "white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
      %s
      "lights": [{"type": "point", "position": [%f, %f, %f], "intensity": [1, 1, 1]}],
      "shapes": [
        {"type": "quad", "material": "mirror", "vertices": [[-6, -6, 0], [6, -6, 0], [6, 6, 0], [-6, 6, 0]]},
        {"type": "quad", "material": "white", "vertices": [[-6, -6, 2], [-6, 6, 2], [6, 6, 2], [6, -6, 2]]}]
    })",
                                                              media, light.x, light.y, light.z),
                                              ".", "mirror.json");
    EXPECT_TRUE(scene.ok()) << scene.status();
    if (scene.ok()) resident.emplace(ResidentScene::upload(*backend, *scene));
  }

  TracedPhotons trace(uint32_t count, uint32_t max_bounces = 64) const {
    PhotonTraceSettings settings;
    settings.photon_count = count;
    settings.max_bounces = max_bounces;
    settings.differentials = true;
    return trace_photons(*backend, *resident, settings);
  }

  // Checks each caustic photon's footprint (grazing ones aside, where first order is far from
  // exact) against a point light's at the light's mirror image, 4 pi r^2 / (n cos theta), grown
  // by exp(sigma r) for the fraction of photons the fog let through; returns how many it checked.
  int check_caustic_footprints(const TracedPhotons& traced, uint32_t count) const {
    const std::vector<Photon> photons = traced.caustic.download();
    const std::vector<PhotonFootprint> footprints = traced.caustic_footprints.download();
    EXPECT_EQ(photons.size(), footprints.size());
    const Vec3f image(light.x, light.y, -light.z);
    int checked = 0;
    for (size_t i = 0; i < photons.size(); ++i) {
      const Vec3f to = photons[i].position - image;
      const float r = length(to), cos_theta = to.z / r;
      if (cos_theta < 0.3f) continue;
      const double expected = 4.0 * kPi * r * r * std::exp(sigma * r) / (count * cos_theta);
      const double got = length(cross(footprints[i].span1, footprints[i].span2));
      EXPECT_NEAR(got / expected, 1.0, 2e-3) << "photon " << i;
      ++checked;
    }
    return checked;
  }
};

// Through the photon tracer: a photon that the mirror sends up lands on the ceiling as if from the
// light's mirror image, and its footprint is that of a point light there, exactly.
TEST(PhotonDifferentials, TracedCausticFootprintsAreThoseOfTheMirroredLight) {
  const MirrorUnderCeiling scene(0.0f);
  const TracedPhotons traced = scene.trace(20000);
  EXPECT_EQ(traced.global_footprints.size(), traced.global.size());
  EXPECT_GT(scene.check_caustic_footprints(traced, 20000), 1000);
}

// The same in grey fog: a photon stopped on its first flight at distance r, where the collisions'
// density is n sigma e^(-sigma r) / (4 pi r^2), has the inverse of that as its footprint volume;
// and one that crossed the fog to the mirror and on to the ceiling has the mirrored light's
// footprint grown by e^(sigma r), the fraction the fog let through (sec. 7.2.1).
TEST(PhotonDifferentials, TracedFootprintsThroughFogAreTheInverseOfTheirDensity) {
  const uint32_t n = 20000;
  const MirrorUnderCeiling scene(0.3f);
  // Paths of one interaction: every collision is a first flight's.
  const TracedPhotons first = scene.trace(n, 1);
  const std::vector<Photon> collisions = first.volume.download();
  const std::vector<float> volumes = first.volume_footprints.download();
  ASSERT_EQ(collisions.size(), volumes.size());
  ASSERT_GT(collisions.size(), 5000u);
  for (size_t i = 0; i < collisions.size(); ++i) {
    const float r = length(collisions[i].position - scene.light);
    if (r < 0.01f) continue;  // where float positions leave too few digits of r
    const double expected = 4.0 * kPi * r * r * std::exp(scene.sigma * r) / (n * scene.sigma);
    EXPECT_NEAR(volumes[i] / expected, 1.0, 2e-3) << "collision " << i << " at distance " << r;
  }
  EXPECT_GT(scene.check_caustic_footprints(scene.trace(n), n), 200);
}

}  // namespace
}  // namespace caustica
