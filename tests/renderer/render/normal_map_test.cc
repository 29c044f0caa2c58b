// Normal maps in every integrator: a diffuse plane under a point light whose tangent-space normal
// map bends the shading normal along the texture's u on one half and up its image on the other,
// against rho / pi I max(0, n . wi) / r^2 with the bent normal n; a flat map changes nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

const char* const kIntegrators[] = {R"({"photons": 20000})",
                                    R"({"estimator": "sppm", "photons": 20000})",
                                    R"({"integrator": "path"})"};

// A texel of a tangent-space normal map, as 8 bits per channel: (n + 1) / 2.
uint8_t encoded(float component) {
  return uint8_t(std::lround(std::clamp(0.5f * (component + 1.0f), 0.0f, 1.0f) * 255.0f));
}

// What a texel of bytes `c` decodes to, (2 c - 1) normalised, x and y times `scale`.
Vec3f decoded(const uint8_t* c, float scale) {
  const auto unit = [](uint8_t b) { return 2.0f * (float(b) / 255.0f) - 1.0f; };
  return normalize(Vec3f(unit(c[0]) * scale, unit(c[1]) * scale, unit(c[2])));
}

// The plane seen from above, u along x and v down y (so up the image is +y), with a map of two
// texels, clamped: the left bends the normal by `tilt` towards +u, the right by `tilt` up the
// image. The light stands off towards +x and +y, so each bend turns the plane towards it and
// the opposite bend, a tangent frame facing the wrong way, away from it. The frame is the
// triangles' own, and then the mesh's tangents: +x, with the bitangent's sign +1, the same.
TEST(NormalMap, BendsTheShadingNormalAlongTheTexturesAxesInEveryIntegrator) {
  const float tilt = 0.6f, scale = 0.8f;
  uint8_t texels[8] = {
      encoded(std::sin(tilt)), encoded(0.0f),           encoded(std::cos(tilt)), 255,
      encoded(0.0f),           encoded(std::sin(tilt)), encoded(std::cos(tilt)), 255};
  const Vec3f left = decoded(texels, scale), right = decoded(texels + 4, scale);
  for (const bool mesh_tangents : {false, true})
    for (const char* settings : kIntegrators) {
      SCOPED_TRACE(settings);
      SCOPED_TRACE(mesh_tangents ? "the mesh's tangents" : "the triangles' own");
      PlaneUnderPointLight plane;
      plane.size = 64;
      plane.light = Vec3f(1.5f, 1.5f, 1.0f);
      Scene scene = plane.scene_with_uvs(settings);
      if (mesh_tangents) {
        Mesh& mesh = scene.meshes.at(0);
        mesh.normals.assign(mesh.positions.size(), Vec3f(0.0f, 0.0f, 1.0f));
        mesh.tangents.assign(mesh.positions.size(), Vec4f{1.0f, 0.0f, 0.0f, 1.0f});
      }
      auto image = std::make_shared<DecodedImage>();
      image->width = 2;
      image->height = 1;
      image->rgba8.assign(texels, texels + 8);
      scene.textures.push_back({"bent-along-u-then-up", nullptr, image});
      Material& m = scene.materials.at(0);
      m.normal_map.texture = 0;
      m.normal_map.wrap_u = m.normal_map.wrap_v = TextureWrap::kClampToEdge;
      m.normal_scale = scale;
      auto engine = engine_with(scene);
      ASSERT_TRUE(engine->render(16).ok());
      const std::span<const float> rendered = engine->image_linear();
      const PinholeCamera cam = PinholeCamera::from(scene.camera);
      double sum = 0, expected_sum = 0, flat_sum = 0, flipped_sum = 0, worst = 0;
      const int checked = PlaneUnderPointLight::visit_square_pixels(
          scene, [&](size_t pixel, int x, int y, float u) {
            // Only where one texel is read: the bilinear lookup blends them in between.
            if (u > 0.2f && u < 0.8f) return;
            Vec3f p;
            ASSERT_TRUE(plane_point(cam, x, y, p));
            const Vec3f n = u < 0.5f ? left : right;
            const Vec3f flipped = u < 0.5f ? Vec3f(-n.x, n.y, n.z) : Vec3f(n.x, -n.y, n.z);
            const Vec3f to_light = plane.light - p;
            const float dist2 = length_squared(to_light);
            const Vec3f wi = normalize(to_light);
            const float light = plane.rho / kPi * plane.intensity / dist2;
            const double expected = light * std::max(0.0f, dot(n, wi));
            const double got = rendered[4 * pixel];
            worst = std::max(worst, std::fabs(got - expected) / expected);
            sum += got;
            expected_sum += expected;
            flat_sum += light * wi.z;
            flipped_sum += light * std::max(0.0f, dot(flipped, wi));
          });
      ASSERT_GT(checked, 80);
      std::printf(
          "normal map, %s, %s: %d pixels, worst %.2f%%, mean %.4f of expected, %.4f unbent, %.4f "
          "with the tangent frame flipped\n",
          mesh_tangents ? "mesh tangents" : "derived frame", settings, checked, 100 * worst,
          sum / expected_sum, flat_sum / expected_sum, flipped_sum / expected_sum);
      EXPECT_NEAR(sum / expected_sum, 1.0, 0.01);
      EXPECT_LT(worst, 0.05);
      EXPECT_GT(std::fabs(flat_sum / expected_sum - 1.0), 0.1);     // the map matters
      EXPECT_GT(std::fabs(flipped_sum / expected_sum - 1.0), 0.1);  // and so do its axes
    }
}

// A normal map of the flat normal, (0.5, 0.5, 1), leaves the image as it was.
TEST(NormalMap, AFlatMapChangesNothing) {
  PlaneUnderPointLight plane;
  plane.size = 48;
  const Scene plain = plane.scene_with_uvs(R"({"photons": 20000})");
  Scene mapped = plain;
  auto image = std::make_shared<DecodedImage>();
  image->width = image->height = 1;
  image->rgba8 = {128, 128, 255, 255};
  mapped.textures.push_back({"flat", nullptr, image});
  mapped.materials.at(0).normal_map.texture = 0;
  auto a = engine_with(plain), b = engine_with(mapped);
  ASSERT_TRUE(a->render(4).ok());
  ASSERT_TRUE(b->render(4).ok());
  const std::span<const float> x = a->image_linear(), y = b->image_linear();
  ASSERT_EQ(x.size(), y.size());
  double worst = 0;
  for (size_t i = 0; i < x.size(); ++i)
    if (x[i] > 0) worst = std::max(worst, double(std::fabs(y[i] - x[i]) / x[i]));
  // 128 / 255 is 0.502: the bend of half a step of 8 bits.
  EXPECT_LT(worst, 0.01);
}

}  // namespace
}  // namespace caustica
