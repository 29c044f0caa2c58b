// The launch order of per-pixel work: consecutive threads walk the image in blocks of 8x4
// pixels, so that the 32 threads of a GPU warp trace neighbouring rays and gather from
// neighbouring photons (coherent node fetches, little divergence). On the CPU the order only
// changes which pixels share a cache.
#pragma once

#include <cstddef>

#include "renderer/base/hd.h"

namespace caustica {

struct PixelBlocks {
  static constexpr int kWidth = 8, kHeight = 4, kPixels = kWidth * kHeight;
  int width = 0, height = 0, blocks_x = 0, blocks_y = 0;

  PixelBlocks(int image_width, int image_height)
      : width(image_width),
        height(image_height),
        blocks_x((image_width + kWidth - 1) / kWidth),
        blocks_y((image_height + kHeight - 1) / kHeight) {}

  // Threads to launch: whole blocks, so edge blocks have threads without a pixel.
  size_t thread_count() const { return size_t(blocks_x) * blocks_y * kPixels; }

  // The pixel (y * width + x) of `thread`, or false for a thread past the image's edge.
  CAUSTICA_HDI bool pixel_of(size_t thread, size_t& pixel) const {
    const size_t block = thread / kPixels;
    const int within = int(thread % kPixels);
    const int x = int(block % blocks_x) * kWidth + within % kWidth;
    const int y = int(block / blocks_x) * kHeight + within / kWidth;
    if (x >= width || y >= height) return false;
    pixel = size_t(y) * width + x;
    return true;
  }
};

}  // namespace caustica
