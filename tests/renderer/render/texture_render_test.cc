// A colour map changes the image only where its texture coordinates say: the square of
// PlaneUnderPointLight, alone under its point light (so every light that reaches the camera was
// reflected once, at the square), with a texture of two texels, red and green, stretched over it.
// Each pixel over the untextured square's is the bilinear lookup at the pixel's point of the
// square, for the photon integrator and the path tracer alike.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "renderer/engine.h"
#include "renderer/render/camera.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// The square with texture coordinates and, with `mapped`, a colour map of two texels (sRGB red,
// then green) clamped at the edges.
Scene square(const std::string& settings, bool mapped) {
  Scene scene = PlaneUnderPointLight{}.scene_with_uvs(settings);
  if (mapped) {
    auto image = std::make_shared<DecodedImage>();
    image->width = 2;
    image->height = 1;
    image->rgba8 = {255, 0, 0, 255, 0, 255, 0, 255};
    scene.textures.push_back({"red-green", nullptr, image});
    TextureRef& map = scene.materials.at(0).color_map;
    map.texture = 0;
    map.wrap_u = map.wrap_v = TextureWrap::kClampToEdge;
  }
  return scene;
}

std::vector<float> render(const Scene& scene) {
  auto engine = engine_with(scene);
  EXPECT_TRUE(engine->render(1).ok());
  const std::span<const float> image = engine->image_linear();
  return std::vector<float>(image.begin(), image.end());
}

void expect_map_where_its_coordinates_say(const std::string& settings) {
  SCOPED_TRACE(settings);
  const Scene plain = square(settings, false), mapped = square(settings, true);
  const std::vector<float> a = render(plain), b = render(mapped);
  ASSERT_EQ(a.size(), b.size());
  int red = 0, green = 0;
  const int checked =
      PlaneUnderPointLight::visit_square_pixels(plain, [&](size_t pixel, int x, int y, float u) {
        // Texel centres at u = 1/4 (red) and 3/4 (green); the ray's jitter moves u by half a
        // pixel.
        const float share = std::clamp((u - 0.25f) / 0.5f, 0.0f, 1.0f);
        const float* p = &a[4 * pixel];
        const float* q = &b[4 * pixel];
        ASSERT_GT(p[0], 0.0f);
        EXPECT_NEAR(q[0] / p[0], 1.0f - share, 0.02f) << x << "," << y;
        EXPECT_NEAR(q[1] / p[1], share, 0.02f) << x << "," << y;
        EXPECT_EQ(q[2], 0.0f) << x << "," << y;
        red += share == 0.0f;
        green += share == 1.0f;
      });
  EXPECT_GT(checked, 400);
  EXPECT_GT(red, 100);
  EXPECT_GT(green, 100);
}

TEST(TextureRender, AColourMapChangesThePhotonImageWhereItsCoordinatesSay) {
  expect_map_where_its_coordinates_say(R"({"photons": 2000})");
}

TEST(TextureRender, AColourMapChangesThePathTracedImageWhereItsCoordinatesSay) {
  expect_map_where_its_coordinates_say(R"({"integrator": "path"})");
}

// A 256 x 256 checkerboard of one-texel red and green checks seen by a 16 x 16 camera: each pixel
// spans about 13 texels, so the photon integrator's camera rays read a level of the mip chain
// where the checks have averaged to (0.5, 0.5, 0), while the path tracer reads single texels.
TEST(TextureRender, CameraRayConesReadTheLevelOfTheirFootprint) {
  auto checkerboard = [](const std::string& settings) {
    PlaneUnderPointLight plane;
    plane.size = 16;
    Scene scene = plane.scene_with_uvs(settings);
    auto image = std::make_shared<DecodedImage>();
    image->width = image->height = 256;
    for (uint32_t y = 0; y < 256; ++y) {
      for (uint32_t x = 0; x < 256; ++x) {
        const bool red = (x + y) % 2 == 0;
        image->rgba8.insert(image->rgba8.end(),
                            {uint8_t(red ? 255 : 0), uint8_t(red ? 0 : 255), 0, 255});
      }
    }
    Scene mapped = scene;
    mapped.textures.push_back({"checks", nullptr, image});
    mapped.materials.at(0).color_map.texture = 0;
    const std::vector<float> a = render(scene), b = render(mapped);
    std::vector<float> red_share;
    for (size_t pixel = 0; pixel < a.size() / 4; ++pixel) {
      const int x = int(pixel % 16), y = int(pixel / 16);
      if (x < 3 || x > 12 || y < 3 || y > 12) continue;  // the square's middle
      red_share.push_back(b[4 * pixel] / a[4 * pixel]);
      EXPECT_NEAR(b[4 * pixel] / a[4 * pixel] + b[4 * pixel + 1] / a[4 * pixel + 1], 1.0f, 1e-3f);
    }
    return red_share;
  };
  for (float share : checkerboard(R"({"photons": 2000})")) EXPECT_NEAR(share, 0.5f, 0.01f);
  int far_from_half = 0;
  const std::vector<float> traced = checkerboard(R"({"integrator": "path"})");
  for (float share : traced) far_from_half += std::fabs(share - 0.5f) > 0.2f;
  EXPECT_GT(far_from_half, int(traced.size()) / 4);
}

}  // namespace
}  // namespace caustica
