// A scene rendered for some passes on one backend, as the GPU suites compare images.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <span>
#include <vector>

#include "renderer/engine.h"
#include "renderer/render/image_error.h"

namespace caustica {

// Fails the test when `image` (linear RGBA, `width` pixels a row) has a value that is not finite,
// naming `device`, how many and the first one's pixel: a comparison with such an image says only
// "nan", whichever backend made it.
inline void expect_finite(std::span<const float> image, uint32_t width, const char* device) {
  size_t bad = 0, first = 0;
  for (size_t i = 0; i < image.size(); ++i) {
    if (std::isfinite(image[i])) continue;
    if (bad++ == 0) first = i;
  }
  EXPECT_EQ(bad, 0u) << device << ": " << bad << " values not finite, the first " << image[first]
                     << " in channel " << first % 4 << " of pixel (" << first / 4 % width << ", "
                     << first / 4 / width << ")";
}

// `scene` loaded into a fresh engine on `device` with `budget` bytes and rendered for `passes`:
// its linear RGBA image, or empty (with the test failed) when any step fails.
inline std::vector<float> render_image(const Scene& scene, DeviceKind device, uint32_t passes,
                                       size_t budget) {
  auto engine = Engine::create({.device = device, .memory_budget_bytes = budget});
  EXPECT_TRUE(engine.ok()) << engine.status();
  if (!engine.ok()) return {};
  absl::StatusOr<RebuildReport> loaded = (*engine)->load(scene);
  EXPECT_TRUE(loaded.ok()) << loaded.status();
  absl::StatusOr<PassReport> rendered = loaded.ok() ? (*engine)->render(passes) : loaded.status();
  EXPECT_TRUE(rendered.ok()) << rendered.status();
  if (!rendered.ok()) return {};
  const std::span<const float> image = (*engine)->image_linear();
  expect_finite(image, scene.camera.width, device == DeviceKind::kCpu ? "CPU" : "GPU");
  return {image.begin(), image.end()};
}

// `scene` rendered for `passes` on the CPU and on the GPU (4 GiB each) and the GPU's image against
// the CPU's; a zero error, with the test failed, when either render fails.
inline ImageError backend_difference(const Scene& scene, uint32_t passes) {
  const std::vector<float> cpu = render_image(scene, DeviceKind::kCpu, passes, size_t{4} << 30);
  const std::vector<float> gpu = render_image(scene, DeviceKind::kCuda, passes, size_t{4} << 30);
  EXPECT_FALSE(cpu.empty());
  EXPECT_EQ(cpu.size(), gpu.size());
  if (cpu.empty() || cpu.size() != gpu.size()) return {};
  return image_error(gpu, cpu, int(scene.camera.width), int(scene.camera.height), 2.0);
}

}  // namespace caustica
