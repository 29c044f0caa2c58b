// Metallic-roughness, Phong and rough glass surfaces in every integrator: a glossy plane under a
// point light and under an area light against the models' own values integrated by brute force,
// and the Cornell box with a glossy metal sphere, a rough glass sphere and a Phong floor, the
// photon integrators against the path tracer.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "renderer/material/metallic_roughness.h"
#include "renderer/material/modified_phong.h"
#include "renderer/render/image_error.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// A glossy model of the plane, by name, and its value for directions in the plane's frame.
struct GlossyPlane {
  const char* name;
  MaterialType type;
  Vec3f color, specular;
  float metallic, roughness, exponent;
  // Under a point light, the most a pixel's jittered samples may differ from the value at its
  // centre: a narrower lobe curves more over a pixel.
  float worst_pixel;

  void apply(Material& m) const {
    m.type = type;
    m.color = color;
    m.specular = specular;
    m.metallic = metallic;
    m.roughness = roughness;
    m.exponent = exponent;
  }
  Vec3f f(Vec3f wo, Vec3f wi) const {
    if (type == MaterialType::kMetallicRoughness)
      return MetallicRoughnessBsdf{color, metallic, roughness}.f(wo, wi);
    return ModifiedPhongBsdf{color, specular, exponent}.f(wo, wi);
  }
};

const GlossyPlane kPlanes[] = {
    {"metallic-roughness", MaterialType::kMetallicRoughness, Vec3f(0.8f, 0.6f, 0.3f), Vec3f(0.0f),
     0.6f, 0.45f, 0.0f, 0.06f},
    {"phong", MaterialType::kPhong, Vec3f(0.4f, 0.3f, 0.2f), Vec3f(0.3f, 0.4f, 0.5f), 0.0f, 0.0f,
     15.0f, 0.06f},
    // Below kNearSpecularAlpha: area lights reach its lobe by the camera path's branch alone.
    {"near-specular metallic-roughness", MaterialType::kMetallicRoughness, Vec3f(0.9f, 0.7f, 0.5f),
     Vec3f(0.0f), 0.5f, 0.2f, 0.0f, 0.2f},
};

const char* const kIntegrators[] = {R"({"photons": 20000})",
                                    R"({"estimator": "sppm", "photons": 20000})",
                                    R"({"integrator": "path"})"};

// The plane under a point light: nothing but the light's own reflection, f(wo, wi) cos I / r^2,
// which only a shadow ray finds. Averaged over each pixel's jittered samples, a pixel differs from
// the value at its centre by the lobe's curvature over it.
TEST(Glossy, APlaneUnderAPointLightReflectsWhatItsModelSays) {
  for (const GlossyPlane& model : kPlanes) {
    for (const char* settings : kIntegrators) {
      PlaneUnderPointLight plane;
      plane.size = 64;
      Scene scene = plane.scene(settings);
      model.apply(scene.materials.at(0));
      auto engine = engine_with(scene);
      ASSERT_TRUE(engine->render(16).ok());
      const std::span<const float> image = engine->image_linear();
      const PinholeCamera cam = PinholeCamera::from(scene.camera);
      double worst = 0, sum = 0, sum_expected = 0;
      int checked = 0;
      for (int y = 1; y < plane.size; y += 2) {
        for (int x = 1; x < plane.size; x += 2) {
          Vec3f p;
          if (!plane_point(cam, x, y, p) || std::fabs(p.x) > 0.95f || std::fabs(p.y) > 0.95f)
            continue;
          const Vec3f to_light = plane.light - p;
          const float dist2 = length_squared(to_light);
          const Vec3f wi = normalize(to_light), wo = normalize(cam.origin - p);
          const Vec3f expected = model.f(wo, wi) * (plane.intensity * wi.z / dist2);
          for (int c = 0; c < 3; ++c) {
            const double e = c == 0 ? expected.x : c == 1 ? expected.y : expected.z;
            const double got = image[4 * (y * plane.size + x) + c];
            worst = std::max(worst, std::fabs(got - e) / e);
            sum += got;
            sum_expected += e;
          }
          ++checked;
        }
      }
      ASSERT_GT(checked, 300);
      std::printf("%s plane under a point light, %s: worst pixel %.2f%%, mean %.4f of expected\n",
                  model.name, settings, 100 * worst, sum / sum_expected);
      EXPECT_NEAR(sum / sum_expected, 1.0, 0.005) << model.name << " " << settings;
      EXPECT_LT(worst, model.worst_pixel) << model.name << " " << settings;
    }
  }
}

// The plane under a square area light: sum over the light of f(wo, wi) Le cos cos' / d^2 dA,
// integrated on a 200 x 200 grid of the light. The photon integrators find the base's share by
// shadow rays and the lobe's by paths that meet the light, the path tracer both ways weighed by
// the power heuristic: a weight or a share wrong in any would move the mean.
TEST(Glossy, APlaneUnderAnAreaLightReflectsItsIntegral) {
  const float le = 2.0f, half = 0.4f, h = 1.0f;
  for (const GlossyPlane& model : kPlanes) {
    for (const char* settings : kIntegrators) {
      Scene scene =
          floor_under_area_light(settings, 0.5f, le, half, h, Vec3f(0.3f, -2.2f, 1.4f), 48, 36);
      model.apply(scene.materials.at(0));
      auto engine = engine_with(scene);
      ASSERT_TRUE(engine->render(512).ok());
      const std::span<const float> image = engine->image_linear();
      const PinholeCamera cam = PinholeCamera::from(scene.camera);
      double sum = 0, sum_expected = 0;
      int checked = 0;
      constexpr int kGrid = 200;
      for (int y = 2; y < 36; y += 4) {
        for (int x = 2; x < 48; x += 4) {
          Vec3f p;
          if (!plane_point(cam, x, y, p) || std::fabs(p.x) > 1.5f || std::fabs(p.y) > 1.5f)
            continue;
          const Vec3f wo = normalize(cam.origin - p);
          Vec3f expected(0.0f);
          const float cell = 2 * half / kGrid;
          for (int j = 0; j < kGrid; ++j) {
            for (int i = 0; i < kGrid; ++i) {
              const Vec3f q(-half + (i + 0.5f) * cell, -half + (j + 0.5f) * cell, h);
              const Vec3f d = q - p;
              const float d2 = length_squared(d);
              const Vec3f wi = d / std::sqrt(d2);
              expected += model.f(wo, wi) * (le * wi.z * wi.z / d2 * cell * cell);
            }
          }
          sum +=
              image[4 * (y * 48 + x)] + image[4 * (y * 48 + x) + 1] + image[4 * (y * 48 + x) + 2];
          sum_expected += expected.x + expected.y + expected.z;
          ++checked;
        }
      }
      ASSERT_GT(checked, 40);
      std::printf("%s plane under an area light, %s: mean %.4f of the integral over %d pixels\n",
                  model.name, settings, sum / sum_expected, checked);
      EXPECT_NEAR(sum / sum_expected, 1.0, 0.025) << model.name << " " << settings;
    }
  }
}

// The bundled glossy Cornell box (the box with caustics, its mirror sphere a glossy metal, its
// glass sphere rough and its white walls, floor and ceiling Phong surfaces): the photon integrators
// against the path tracer's image, region by region, at 48 x 48 (docs/materials.md, "In the
// integrators", has the figures).
TEST(Glossy, ThePhotonIntegratorsMatchThePathTracerInAGlossyCornellBox) {
  absl::StatusOr<Scene> loaded =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/cornell-glossy/scene.json");
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  constexpr int kSide = 48;
  loaded->camera.width = loaded->camera.height = kSide;
  auto render = [&](const char* what, uint32_t passes) {
    Scene s = *loaded;
    if (std::string(what) == "path") s.settings.integrator = Integrator::kPath;
    if (std::string(what) == "sppm") s.settings.estimator = EstimatorKind::kSppm;
    s.settings.photons_per_pass = 100000;
    auto engine = engine_with(s);
    EXPECT_TRUE(engine->render(passes).ok());
    const std::span<const float> image = engine->image_linear();
    return std::vector<float>(image.begin(), image.end());
  };
  const std::vector<float> reference = render("path", 4096);
  for (const char* what : {"knn", "sppm"}) {
    const std::vector<float> image = render(what, 64);
    const ImageError e = image_error(image, reference, kSide, kSide, 2.0);
    std::printf("glossy Cornell box, %s against the path tracer: worst region %.2f%%, mean %.4f\n",
                what, 100 * e.worst_region, e.mean_ratio);
    print_region_errors(e);
    // The worst region is where the metal sphere meets the floor: a search there reaches into the
    // sphere, which stores no photons, as both estimators' radii do at every contact.
    EXPECT_NEAR(e.mean_ratio, 1.0, 0.02) << what;
    EXPECT_LT(e.worst_region, 0.2) << what;
  }
}

}  // namespace
}  // namespace caustica
namespace caustica {
namespace {
// Inside a closed sphere (analytic_scenes.h) whose wall is a Phong surface with no glossy lobe:
// the Lambertian sphere's interreflection series, through the sampled models' code.
TEST(Glossy, APhongSphereWithoutALobeIsTheDiffuseSphere) {
  const InsideDiffuseSphere sphere;
  for (const char* settings : kIntegrators) {
    Scene s = sphere.scene(settings);
    s.materials.at(0).type = MaterialType::kPhong;
    s.materials.at(0).specular = Vec3f(0.0f);
    auto engine = engine_with(s);
    ASSERT_TRUE(engine->render(16).ok());
    const double mean = InsideDiffuseSphere::mean(engine->image_linear());
    std::printf("%s: phong sphere %.5f, analytic %.5f\n", settings, mean, sphere.expected());
    EXPECT_NEAR(mean / sphere.expected(), 1.0, 0.02) << settings;
  }
}
}  // namespace
}  // namespace caustica
namespace caustica {
namespace {
// A Phong surface with no glossy lobe is the Lambertian one, whichever way it faces: a floor lit by
// an area light under a ceiling lit only by the floor, each in turn made such a Phong surface,
// renders as with both diffuse. (Each sampled direction's cosine is taken in its shading frame,
// not along the world's z axis.)
TEST(Glossy, APhongSurfaceWithoutALobeIsTheDiffuseOneFacingAnyWay) {
  const auto render = [](const char* settings, const char* phong_surface) {
    Scene scene = parse_or_die(absl::StrFormat(R"({
      "camera": {"position": [0.3, 0.5, -2.5], "look_at": [0, 1, 0], "up": [0, 1, 0],
                 "fov": 50, "width": 32, "height": 32},
      "settings": %s,
      "materials": {"ceiling": {"type": "diffuse", "albedo": [0.7, 0.7, 0.7]},
                    "floor": {"type": "diffuse", "albedo": [0.7, 0.7, 0.7]},
                    "lamp": {"type": "emissive", "radiance": [5, 5, 5]}},
      "shapes": [{"type": "quad", "material": "floor",
                  "vertices": [[-3, 0, -3], [-3, 0, 3], [3, 0, 3], [3, 0, -3]]},
                 {"type": "quad", "material": "ceiling",
                  "vertices": [[-3, 1, -3], [3, 1, -3], [3, 1, 3], [-3, 1, 3]]},
                 {"type": "quad", "material": "lamp",
                  "vertices": [[-0.3, 0.9, -0.3], [0.3, 0.9, -0.3], [0.3, 0.9, 0.3],
                               [-0.3, 0.9, 0.3]]}]
    })",
                                               settings));
    for (Material& m : scene.materials) {
      if (m.name != phong_surface) continue;
      m.type = MaterialType::kPhong;
      m.specular = Vec3f(0.0f);
    }
    auto engine = engine_with(scene);
    EXPECT_TRUE(engine->render(128).ok());
    const std::span<const float> image = engine->image_linear();
    double sum = 0;
    for (size_t i = 0; i < image.size(); i += 4)
      if (image[i] < 2.0f) sum += image[i];  // the lamp's own pixels left out
    return sum;
  };
  for (const char* settings : kIntegrators) {
    const double diffuse = render(settings, "");
    for (const char* surface : {"floor", "ceiling"}) {
      const double phong = render(settings, surface);
      std::printf("%s, %s a Phong surface without a lobe: %.4f of the diffuse image\n", settings,
                  surface, phong / diffuse);
      EXPECT_NEAR(phong / diffuse, 1.0, 0.015) << settings << " " << surface;
    }
  }
}
}  // namespace
}  // namespace caustica

namespace caustica {
namespace {

// PlaneUnderPointLight's square as a metallic-roughness surface of factors 1 and 1 under a map of
// two texels, clamped: rough dielectric (green 255, blue 0) on the left, smooth-ish metal (green
// 77, blue 255) on the right, read linearly. Each pixel is the model's value with the map's
// bilinear lookup at its point, f(wo, wi) cos I / r^2.
TEST(Glossy, AMetallicRoughnessMapSetsMetalnessAndRoughnessWhereItsCoordinatesSay) {
  const Vec3f base(0.8f, 0.6f, 0.3f);
  for (const char* settings : kIntegrators) {
    SCOPED_TRACE(settings);
    PlaneUnderPointLight plane;
    plane.size = 64;
    Scene scene = plane.scene_with_uvs(settings);
    auto image = std::make_shared<DecodedImage>();
    image->width = 2;
    image->height = 1;
    image->rgba8 = {0, 255, 0, 255, 0, 77, 255, 255};
    scene.textures.push_back({"rough-dielectric-then-metal", nullptr, image});
    Material& m = scene.materials.at(0);
    m.type = MaterialType::kMetallicRoughness;
    m.color = base;
    m.metallic = 1.0f;
    m.roughness = 1.0f;
    m.metallic_roughness_map.texture = 0;
    m.metallic_roughness_map.wrap_u = m.metallic_roughness_map.wrap_v = TextureWrap::kClampToEdge;
    auto engine = engine_with(scene);
    ASSERT_TRUE(engine->render(16).ok());
    const std::span<const float> rendered = engine->image_linear();
    const PinholeCamera cam = PinholeCamera::from(scene.camera);
    double sum = 0, sum_expected = 0, sum_unmapped = 0, worst = 0;
    const int checked = PlaneUnderPointLight::visit_square_pixels(scene, [&](size_t pixel, int x,
                                                                             int y, float u) {
      Vec3f p;
      ASSERT_TRUE(plane_point(cam, x, y, p));
      const float t = std::clamp((u - 0.25f) / 0.5f, 0.0f, 1.0f);
      const float metallic = t, roughness = 1.0f + t * (77.0f / 255.0f - 1.0f);
      const Vec3f to_light = plane.light - p;
      const float dist2 = length_squared(to_light);
      const Vec3f wi = normalize(to_light), wo = normalize(cam.origin - p);
      const float light = plane.intensity * wi.z / dist2;
      const double expected = MetallicRoughnessBsdf{base, metallic, roughness}.f(wo, wi).y * light;
      const double got = rendered[4 * pixel + 1];
      worst = std::max(worst, std::fabs(got - expected) / expected);
      sum += got;
      sum_expected += expected;
      sum_unmapped += MetallicRoughnessBsdf{base, 1.0f, 1.0f}.f(wo, wi).y * light;
    });
    ASSERT_GT(checked, 200);
    std::printf(
        "metallic-roughness map, %s: worst pixel %.2f%%, mean %.4f of expected, %.4f "
        "unmapped\n",
        settings, 100 * worst, sum / sum_expected, sum_unmapped / sum_expected);
    // A pixel's samples read the map across its footprint, where the lobe changes fastest.
    EXPECT_NEAR(sum / sum_expected, 1.0, 0.01);
    EXPECT_LT(worst, 0.15);
    EXPECT_GT(std::fabs(sum_unmapped / sum_expected - 1.0), 0.1);  // the map matters
  }
}

}  // namespace
}  // namespace caustica
