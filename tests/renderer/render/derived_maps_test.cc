// Maps derived at upload: normals from a height (bump) map against its ramps' slopes, wrapped as
// the map wraps, and rendered in every integrator against rho / pi I max(0, n . wi) / r^2 with
// those normals; separate roughness and metalness maps packed into glTF's layout, rendering
// exactly as the packed map of the same values.
#include "renderer/resident/derived_maps.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// A float image whose first channel is `height(x, row)`, the others filled with noise that the
// derivation must not read.
std::shared_ptr<DecodedImage> float_heights(uint32_t w, uint32_t h, auto height) {
  auto image = std::make_shared<DecodedImage>();
  image->width = w;
  image->height = h;
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x)
      image->rgba32f.insert(image->rgba32f.end(), {height(x, y), float(x * 7 % 5), 9.0f, 1.0f});
  return image;
}

// The unit normal a derived texel encodes.
Vec3f normal_of(const Texel& t) { return normalize(Vec3f(2 * t.r - 1, 2 * t.g - 1, 2 * t.b - 1)); }

void expect_normal(const Texel& t, Vec3f expected, const char* where) {
  const Vec3f n = normal_of(t), e = normalize(expected);
  EXPECT_NEAR(n.x, e.x, 1e-5f) << where;
  EXPECT_NEAR(n.y, e.y, 1e-5f) << where;
  EXPECT_NEAR(n.z, e.z, 1e-5f) << where;
}

// Heights a x + b row, scaled by s: every inner texel has the slopes s a along u and -s b up the
// image (rows run down it), so the normal (-s a, s b, 1); the first column's left neighbour is
// the last column when the map repeats, and itself when it clamps or mirrors.
TEST(DerivedMaps, NormalsFromHeightsAreTheRampsSlopesWrappedAsTheMapWraps) {
  const float a = 0.125f, b = -0.0625f, s = 3.0f;
  const uint32_t w = 6, h = 5;
  const auto image = float_heights(w, h, [&](uint32_t x, uint32_t y) { return a * x + b * y; });
  for (const TextureWrap wrap :
       {TextureWrap::kRepeat, TextureWrap::kClampToEdge, TextureWrap::kMirroredRepeat}) {
    const std::vector<Texel> n = normals_from_heights(*image, s, wrap, wrap);
    ASSERT_EQ(n.size(), size_t(w) * h);
    for (uint32_t y = 1; y + 1 < h; ++y)
      for (uint32_t x = 1; x + 1 < w; ++x) expect_normal(n[y * w + x], {-s * a, s * b, 1}, "inner");
    // Column 0, row 2: h(1) - h(left), halved.
    const float left = wrap == TextureWrap::kRepeat ? a * (w - 1) : 0.0f;
    expect_normal(n[2 * w], {-s * 0.5f * (a - left), s * b, 1}, "first column");
    // Row 0, column 2: up from row 0 is the last row when repeating, row 0 otherwise.
    const float up = wrap == TextureWrap::kRepeat ? b * (h - 1) : 0.0f;
    expect_normal(n[2], {-s * a, -s * 0.5f * (up - b), 1}, "first row");
  }
  // 8-bit heights are their first channel over 255.
  auto bytes = std::make_shared<DecodedImage>();
  bytes->width = 3;
  bytes->height = 1;
  bytes->rgba8 = {0, 200, 7, 255, 51, 0, 0, 255, 102, 90, 1, 255};
  const std::vector<Texel> n =
      normals_from_heights(*bytes, 1.0f, TextureWrap::kClampToEdge, TextureWrap::kClampToEdge);
  expect_normal(n[1], {-0.2f, 0, 1}, "8-bit");
}

// Green is the roughness map's first channel, blue the metalness map's sampled bilinearly at the
// same place in the larger image's grid, 1 where a map is missing.
TEST(DerivedMaps, SeparateMapsArePackedAsGltfPacksThem) {
  DecodedImage roughness;
  roughness.width = 4;
  roughness.height = 2;
  for (int i = 0; i < 8; ++i)
    roughness.rgba8.insert(roughness.rgba8.end(), {uint8_t(30 * i), 255, 0, 255});
  DecodedImage metallic;
  metallic.width = 2;
  metallic.height = 1;
  metallic.rgba32f = {0.2f, 0, 0, 1, 0.6f, 0, 0, 1};
  const PackedImage packed = packed_metallic_roughness(&roughness, &metallic);
  ASSERT_EQ(packed.width, 4u);
  ASSERT_EQ(packed.height, 2u);
  const float blue[4] = {0.2f, 0.75f * 0.2f + 0.25f * 0.6f, 0.25f * 0.2f + 0.75f * 0.6f, 0.6f};
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) {
      const Texel& t = packed.texels[y * 4 + x];
      EXPECT_FLOAT_EQ(t.g, float(30 * (y * 4 + x)) / 255.0f);
      EXPECT_NEAR(t.b, blue[x], 1e-6f) << x;
    }
  const PackedImage metal_only = packed_metallic_roughness(nullptr, &metallic);
  ASSERT_EQ(metal_only.width, 2u);
  EXPECT_EQ(metal_only.texels[1].g, 1.0f);
  EXPECT_FLOAT_EQ(metal_only.texels[1].b, 0.6f);
}

const char* const kIntegrators[] = {R"({"photons": 20000})",
                                    R"({"estimator": "sppm", "photons": 20000})",
                                    R"({"integrator": "path"})"};

// The plane of the normal-map tests under a bump map of heights a x + b row, clamped: inside,
// the normal (-s a, s b, 1) turns the plane towards the light, in every integrator. A normal map
// given as well takes precedence: a flat one leaves the plane unbent.
TEST(DerivedMaps, ABumpMapBendsThePlaneByItsSlopesInEveryIntegrator) {
  const float a = -0.15f, b = 0.1f, s = 2.0f;
  const auto heights =
      float_heights(16, 16, [&](uint32_t x, uint32_t y) { return 4.0f + a * x + b * y; });
  const Vec3f n = normalize(Vec3f(-s * a, s * b, 1));
  for (const bool with_normal_map : {false, true})
    for (const char* settings : kIntegrators) {
      SCOPED_TRACE(settings);
      SCOPED_TRACE(with_normal_map ? "with a flat normal map" : "the bump map alone");
      PlaneUnderPointLight plane;
      plane.size = 64;
      plane.light = Vec3f(1.5f, 1.5f, 1.0f);
      Scene scene = plane.scene_with_uvs(settings);
      scene.textures.push_back({"ramps", nullptr, heights});
      Material& m = scene.materials.at(0);
      m.bump_map.texture = 0;
      m.bump_map.wrap_u = m.bump_map.wrap_v = TextureWrap::kClampToEdge;
      m.bump_scale = s;
      if (with_normal_map) {
        auto flat = std::make_shared<DecodedImage>();
        flat->width = flat->height = 1;
        flat->rgba32f = {0.5f, 0.5f, 1.0f, 1.0f};
        scene.textures.push_back({"flat", nullptr, flat});
        m.normal_map.texture = 1;
      }
      auto engine = engine_with(scene);
      ASSERT_TRUE(engine->render(16).ok());
      const std::span<const float> rendered = engine->image_linear();
      const PinholeCamera cam = PinholeCamera::from(scene.camera);
      double sum = 0, expected_sum = 0, unbent_sum = 0, worst = 0;
      const int checked = PlaneUnderPointLight::visit_square_pixels(
          scene, [&](size_t pixel, int x, int y, float u) {
            Vec3f p;
            ASSERT_TRUE(plane_point(cam, x, y, p));
            const float v = 0.5f * (1.0f - p.y);
            // Away from the edge texels, whose one-sided differences halve the slopes.
            if (u < 0.15f || u > 0.85f || v < 0.15f || v > 0.85f) return;
            const Vec3f to_light = plane.light - p;
            const Vec3f wi = normalize(to_light);
            const Vec3f normal = with_normal_map ? Vec3f(0, 0, 1) : n;
            const double light = plane.rho / kPi * plane.intensity / length_squared(to_light);
            const double expected = light * std::max(0.0f, dot(normal, wi));
            unbent_sum += light * wi.z;
            const double got = rendered[4 * pixel];
            worst = std::max(worst, std::fabs(got - expected) / expected);
            sum += got;
            expected_sum += expected;
          });
      ASSERT_GT(checked, 100);
      std::printf("bump map, %s%s: %d pixels, worst %.2f%%, mean %.4f of expected\n", settings,
                  with_normal_map ? " under a flat normal map" : "", checked, 100 * worst,
                  sum / expected_sum);
      EXPECT_NEAR(sum / expected_sum, 1.0, 0.01);
      EXPECT_LT(worst, 0.05);
      if (!with_normal_map) EXPECT_GT(std::fabs(unbent_sum / expected_sum - 1.0), 0.1);
    }
}

// A metallic-roughness plane whose roughness and metalness come from two images renders exactly
// as the one whose packed map holds the same values.
TEST(DerivedMaps, SeparateMapsRenderAsTheirPackedMap) {
  PlaneUnderPointLight plane;
  plane.size = 48;
  Scene packed = plane.scene_with_uvs(R"({"photons": 20000})");
  Material& m = packed.materials.at(0);
  m.type = MaterialType::kMetallicRoughness;
  m.color = Vec3f(0.8f, 0.6f, 0.4f);
  m.metallic = 1.0f;
  m.roughness = 1.0f;
  auto orm = std::make_shared<DecodedImage>(), rough = std::make_shared<DecodedImage>(),
       metal = std::make_shared<DecodedImage>();
  for (auto* image : {orm.get(), rough.get(), metal.get()}) image->width = image->height = 4;
  for (int i = 0; i < 16; ++i) {
    const uint8_t r = uint8_t(40 + 13 * i), k = uint8_t(255 - 16 * i);
    orm->rgba8.insert(orm->rgba8.end(), {77, r, k, 255});
    rough->rgba8.insert(rough->rgba8.end(), {r, r, r, 255});
    metal->rgba8.insert(metal->rgba8.end(), {k, 3, 250, 255});
  }
  Scene separate = packed;
  packed.textures.push_back({"orm", nullptr, orm});
  packed.materials.at(0).metallic_roughness_map.texture = 0;
  separate.textures.push_back({"rough", nullptr, rough});
  separate.textures.push_back({"metal", nullptr, metal});
  separate.materials.at(0).roughness_map.texture = 0;
  separate.materials.at(0).metallic_map.texture = 1;
  auto a = engine_with(packed), b = engine_with(separate);
  ASSERT_TRUE(a->render(4).ok());
  ASSERT_TRUE(b->render(4).ok());
  const std::span<const float> x = a->image_linear(), y = b->image_linear();
  ASSERT_EQ(x.size(), y.size());
  size_t lit = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    ASSERT_EQ(x[i], y[i]) << i;
    lit += x[i] > 0;
  }
  EXPECT_GT(lit, x.size() / 4);
}

}  // namespace
}  // namespace caustica
