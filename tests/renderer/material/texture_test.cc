// Textures against values computed by hand: bilinear lookups at and between texel centres under
// each wrap mode, the mip chain's box filter, the trilinear level from a footprint, the sRGB
// transfer function and KHR_texture_transform.
#include "renderer/material/texture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace caustica {
namespace {

// A texture of its own mip chain, viewed.
struct Texture {
  MipChain chain;
  TextureView view;
  Texture(uint32_t width, uint32_t height, const std::vector<Texel>& image,
          TextureWrap wrap = TextureWrap::kRepeat)
      : chain(build_mip_chain(width, height, image)) {
    view = {chain.texels.data(), chain.levels.data(), uint32_t(chain.levels.size()), wrap, wrap};
  }
};

// A 4 x 2 image whose red channel is the texel's index and green its column.
std::vector<Texel> indexed(uint32_t width, uint32_t height) {
  std::vector<Texel> image;
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) image.push_back({float(y * width + x), float(x), 0, 1});
  return image;
}

TEST(Texture, BilinearIsExactAtTexelCentresAndLinearBetween) {
  const Texture t(4, 2, indexed(4, 2));
  // Texel (1, 1)'s centre: u = 1.5 / 4, v = 1.5 / 2.
  EXPECT_FLOAT_EQ(t.view.bilinear(0, {1.5f / 4, 1.5f / 2}).r, 5.0f);
  // Half way between texels (1, 0) and (2, 0), and between (1, 0) and (1, 1).
  EXPECT_FLOAT_EQ(t.view.bilinear(0, {2.0f / 4, 0.5f / 2}).r, 1.5f);
  EXPECT_FLOAT_EQ(t.view.bilinear(0, {1.5f / 4, 1.0f / 2}).r, 3.0f);
  // A quarter of the way from (1, 0) towards (2, 1): the four texels weighted 9, 3, 3, 1 / 16.
  const float r = t.view.bilinear(0, {1.75f / 4, 0.75f / 2}).r;
  EXPECT_FLOAT_EQ(r, (9 * 1 + 3 * 2 + 3 * 5 + 1 * 6) / 16.0f);
}

TEST(Texture, WrapModesReadTheRightTexelsOutside) {
  const std::vector<Texel> image = indexed(4, 1);
  // Half way between the last texel and the first: repeat blends them, clamp keeps the edge,
  // mirrored repeat reads the last texel again.
  const Vec2f seam{4.0f / 4, 0.5f};
  EXPECT_FLOAT_EQ(Texture(4, 1, image, TextureWrap::kRepeat).view.bilinear(0, seam).g, 1.5f);
  EXPECT_FLOAT_EQ(Texture(4, 1, image, TextureWrap::kClampToEdge).view.bilinear(0, seam).g, 3.0f);
  EXPECT_FLOAT_EQ(Texture(4, 1, image, TextureWrap::kMirroredRepeat).view.bilinear(0, seam).g,
                  3.0f);
  // One period on, repeat reads the same; mirrored reads the texture backwards.
  EXPECT_FLOAT_EQ(
      Texture(4, 1, image, TextureWrap::kRepeat).view.bilinear(0, {1.5f / 4 + 1, 0.5f}).g, 1.0f);
  EXPECT_FLOAT_EQ(
      Texture(4, 1, image, TextureWrap::kMirroredRepeat).view.bilinear(0, {1.5f / 4 + 1, 0.5f}).g,
      2.0f);
  EXPECT_EQ(TextureView::wrap(-1, 4, TextureWrap::kRepeat), 3);
  EXPECT_EQ(TextureView::wrap(-1, 4, TextureWrap::kMirroredRepeat), 0);
  EXPECT_EQ(TextureView::wrap(9, 4, TextureWrap::kMirroredRepeat), 1);  // 0123 3210 0123
  EXPECT_EQ(TextureView::wrap(13, 4, TextureWrap::kMirroredRepeat), 2);
  EXPECT_EQ(TextureView::wrap(-7, 4, TextureWrap::kClampToEdge), 0);
}

TEST(Texture, MipChainAveragesTwoByTwoBlocksDownToOneTexel) {
  const Texture t(4, 2, indexed(4, 2));
  ASSERT_EQ(t.chain.levels.size(), 3u);  // 4x2, 2x1, 1x1
  const MipLevel& l1 = t.chain.levels[1];
  EXPECT_EQ(l1.width, 2u);
  EXPECT_EQ(l1.height, 1u);
  EXPECT_FLOAT_EQ(t.view.at(l1, 0, 0).r, (0 + 1 + 4 + 5) / 4.0f);
  EXPECT_FLOAT_EQ(t.view.at(l1, 1, 0).r, (2 + 3 + 6 + 7) / 4.0f);
  EXPECT_FLOAT_EQ(t.view.at(t.chain.levels[2], 0, 0).r, 3.5f);  // the mean of 0..7
  // An odd size: 3 wide halves to 2, the last column counted for both halves of its texel.
  const Texture odd(3, 1, indexed(3, 1));
  EXPECT_EQ(odd.chain.levels[1].width, 2u);
  EXPECT_FLOAT_EQ(odd.view.at(odd.chain.levels[1], 1, 0).r, 2.0f);
}

TEST(Texture, TrilinearPicksTheLevelOfTheFootprint) {
  // 8 x 8 of checkers one texel wide: level 0 alternates 0 and 1, every coarser level is 0.5.
  std::vector<Texel> checker;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) checker.push_back({float((x + y) % 2), 0, 0, 1});
  const Texture t(8, 8, checker);
  const Vec2f centre{0.5f / 8, 0.5f / 8};                       // texel (0, 0), value 0
  EXPECT_FLOAT_EQ(t.view.trilinear(centre, 0.0f).r, 0.0f);      // narrower than a texel
  EXPECT_FLOAT_EQ(t.view.trilinear(centre, 1.0f / 8).r, 0.0f);  // one texel: level 0
  EXPECT_FLOAT_EQ(t.view.trilinear(centre, 2.0f / 8).r, 0.5f);  // two texels: level 1
  EXPECT_NEAR(t.view.trilinear(centre, std::sqrt(2.0f) / 8).r, 0.25f, 1e-6f);  // level 0.5
  EXPECT_FLOAT_EQ(t.view.trilinear(centre, 100.0f).r, 0.5f);  // wider than the texture
}

// A texture changes a lookup only where its coordinates fall: each quadrant of a 2 x 2 texture
// reads its own texel at its centre, whatever the others hold.
TEST(Texture, ALookupReadsOnlyTheTexelsAroundItsCoordinates) {
  std::vector<Texel> image = {{1, 0, 0, 1}, {2, 0, 0, 1}, {3, 0, 0, 1}, {4, 0, 0, 1}};
  const Texture before(2, 2, image, TextureWrap::kClampToEdge);
  image[3].r = 40;
  const Texture after(2, 2, image, TextureWrap::kClampToEdge);
  for (const Vec2f uv : {Vec2f{0.25f, 0.25f}, Vec2f{0.75f, 0.25f}, Vec2f{0.25f, 0.75f}})
    EXPECT_EQ(before.view.bilinear(0, uv).r, after.view.bilinear(0, uv).r);
  EXPECT_FLOAT_EQ(after.view.bilinear(0, {0.75f, 0.75f}).r, 40.0f);
}

TEST(Texture, SrgbTransferRoundTrips) {
  EXPECT_FLOAT_EQ(srgb_to_linear(0.0f), 0.0f);
  EXPECT_FLOAT_EQ(srgb_to_linear(1.0f), 1.0f);
  EXPECT_NEAR(srgb_to_linear(0.5f), 0.2140411f, 1e-6f);
  EXPECT_NEAR(srgb_to_linear(0.04045f), 0.04045f / 12.92f, 1e-9f);  // the linear segment's end
  for (int i = 0; i <= 255; ++i) {
    const float v = i / 255.0f;
    EXPECT_NEAR(linear_to_srgb(srgb_to_linear(v)), v, 2e-6f) << i;
  }
}

// KHR_texture_transform's matrices, scale first, then rotation, then offset: with offset (0, 1),
// rotation pi / 2 and scale (2, 2), (1, 0) goes to (2, 0), (0, 2) and (0, 3); (0, 1) to (0, 2),
// (-2, 0) and (-2, 1).
TEST(Texture, TextureTransformFollowsTheExtension) {
  const TextureTransform t{{0.0f, 1.0f}, 1.5707963f, {2.0f, 2.0f}};
  const Vec2f a = t.apply({1.0f, 0.0f}), b = t.apply({0.0f, 1.0f});
  EXPECT_NEAR(a.x, 0.0f, 1e-6f);
  EXPECT_NEAR(a.y, 3.0f, 1e-6f);
  EXPECT_NEAR(b.x, -2.0f, 1e-6f);
  EXPECT_NEAR(b.y, 1.0f, 1e-6f);
  const Vec2f identity = TextureTransform{}.apply({0.3f, 0.7f});
  EXPECT_FLOAT_EQ(identity.x, 0.3f);
  EXPECT_FLOAT_EQ(identity.y, 0.7f);
}

}  // namespace
}  // namespace caustica
