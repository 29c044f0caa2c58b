// A scene rendered for some passes on one backend, as the GPU suites compare images.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <span>
#include <vector>

#include "renderer/engine.h"

namespace caustica {

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
  return {image.begin(), image.end()};
}

}  // namespace caustica
