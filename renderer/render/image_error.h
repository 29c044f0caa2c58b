// An image's error against a reference of the same size (RGBA float, top row first), as the
// convergence benchmark and the estimators' tests measure it: the relative RMS error over every
// pixel, the mean luminance of each of 8 x 8 regions against the reference's, and the image's mean.
//
// Optionally the pixels that see a light directly, and their neighbours, are left out: at a light's
// edge a pixel's value is the share of its jittered samples that hit the light, many times brighter
// than the walls, and in a small image that sampling noise (which every integrator shares at one
// seed) outweighs the reflected light the estimators differ in.
#pragma once

#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

namespace caustica {

// Regions per side of the image whose mean luminance is compared.
constexpr int kErrorRegionsPerSide = 8;
// A region darker than this share of the reference's mean region is left out of the worst region:
// its relative error says little.
constexpr double kDarkRegionShare = 0.02;

struct ImageError {
  double relative_rmse = 0;  // over every pixel and channel, relative to the reference's RMS
  double worst_region = 0;   // the largest |region mean / reference region mean - 1|
  double mean_ratio = 0;     // the image's mean luminance over the reference's
  // Each region's mean / reference region mean - 1, row-major from the top-left; 0 where dark.
  std::vector<double> region_errors;
};

inline double rgb_luminance(const float* rgba) {
  return (double(rgba[0]) + rgba[1] + rgba[2]) / 3.0;
}

// `exclude_above`: the pixels whose reference luminance exceeds it, and their eight neighbours,
// count in no region (nor in the means and the RMS error).
inline ImageError image_error(std::span<const float> image, std::span<const float> reference,
                              int width, int height, double exclude_above = INFINITY) {
  ImageError e;
  std::vector<char> excluded(size_t(width) * height, 0);
  if (std::isfinite(exclude_above)) {
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        if (rgb_luminance(&reference[4 * (size_t(y) * width + x)]) <= exclude_above) continue;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int nx = x + dx, ny = y + dy;
            if (nx >= 0 && ny >= 0 && nx < width && ny < height)
              excluded[size_t(ny) * width + nx] = 1;
          }
      }
  }
  double difference = 0, sum = 0, mean = 0, mean_reference = 0;
  constexpr int kRegions = kErrorRegionsPerSide * kErrorRegionsPerSide;
  std::vector<double> region(kRegions, 0.0), region_reference(kRegions, 0.0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (excluded[size_t(y) * width + x]) continue;
      const size_t i = 4 * (size_t(y) * width + x);
      for (int c = 0; c < 3; ++c) {
        const double d = double(image[i + c]) - reference[i + c];
        difference += d * d;
        sum += double(reference[i + c]) * reference[i + c];
      }
      const size_t r = size_t(y * kErrorRegionsPerSide / height) * kErrorRegionsPerSide +
                       size_t(x * kErrorRegionsPerSide / width);
      region[r] += rgb_luminance(&image[i]);
      region_reference[r] += rgb_luminance(&reference[i]);
      mean += rgb_luminance(&image[i]);
      mean_reference += rgb_luminance(&reference[i]);
    }
  }
  e.relative_rmse = sum > 0 ? std::sqrt(difference / sum) : 0.0;
  e.mean_ratio = mean_reference > 0 ? mean / mean_reference : 0.0;
  const double dark = kDarkRegionShare * mean_reference / double(kRegions);
  e.region_errors.assign(kRegions, 0.0);
  for (int r = 0; r < kRegions; ++r) {
    if (region_reference[r] <= dark) continue;
    e.region_errors[r] = region[r] / region_reference[r] - 1.0;
    e.worst_region = std::max(e.worst_region, std::fabs(e.region_errors[r]));
  }
  return e;
}

}  // namespace caustica
