// Scenes with closed-form answers, and the engine helpers, shared by the integrators' suites.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <span>
#include <string>

#include "absl/strings/str_format.h"
#include "renderer/engine.h"
#include "renderer/render/camera.h"
#include "renderer/render/image_error.h"
#include "renderer/scene/load_scene.h"

namespace caustica {

// Prints each region's error of `e` in percent, a row of regions per line.
inline void print_region_errors(const ImageError& e) {
  for (int r = 0; r < kErrorRegionsPerSide * kErrorRegionsPerSide; ++r)
    std::printf("%+6.1f%s", 100 * e.region_errors[r],
                r % kErrorRegionsPerSide == kErrorRegionsPerSide - 1 ? "\n" : " ");
}

// `base_dir`: where the scene's files are.
inline Scene parse_or_die(const std::string& json, const std::filesystem::path& base_dir = ".") {
  absl::StatusOr<Scene> scene = parse_scene(json, base_dir, "test.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  return scene.ok() ? *scene : Scene{};
}

inline std::unique_ptr<Engine> engine_with(const Scene& scene) {
  auto engine = Engine::create({});
  EXPECT_TRUE(engine.ok());
  auto loaded = (*engine)->load(scene);
  EXPECT_TRUE(loaded.ok()) << loaded.status();
  return std::move(*engine);
}

// Where the ray through the centre of pixel (x, y) meets the plane z = 0, when it goes down.
inline bool plane_point(const PinholeCamera& camera, int x, int y, Vec3f& p) {
  const Ray r = camera.ray_through(float(x) + 0.5f, float(y) + 0.5f);
  if (!(r.direction.z < 0.0f)) return false;
  p = r.origin + r.direction * (-r.origin.z / r.direction.z);
  return true;
}

// A 2 x 2 diffuse square of albedo rho at z = 0, seen from above by a `size` x `size` camera, lit
// by a point light of intensity I at `light`: no other surface, so every point's radiance is
// rho / pi * I cos(theta) / r^2. `settings` is the scene's settings object.
struct PlaneUnderPointLight {
  float rho = 0.6f, intensity = 3.0f;
  Vec3f light{0.3f, -0.2f, 1.0f};
  int size = 128;

  Scene scene(const std::string& settings) const {
    return parse_or_die(absl::StrFormat(R"({
      "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 30,
                 "width": %d, "height": %d},
      "settings": %s,
      "materials": {"grey": {"type": "diffuse", "albedo": [%f, %f, %f]}},
      "lights": [{"type": "point", "position": [%f, %f, %f], "intensity": [%f, %f, %f]}],
      "shapes": [{"type": "quad", "material": "grey",
                  "vertices": [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]}]
    })",
                                        size, size, settings, rho, rho, rho, light.x, light.y,
                                        light.z, intensity, intensity, intensity));
  }

  // The scene with texture coordinates from the square's corners, u along x and v down y
  // (glTF's).
  Scene scene_with_uvs(const std::string& settings) const {
    Scene s = scene(settings);
    Mesh& mesh = s.meshes.at(0);
    mesh.uvs.clear();
    for (const Vec3f& p : mesh.positions)
      mesh.uvs.push_back({0.5f * (p.x + 1.0f), 0.5f * (1.0f - p.y)});
    return s;
  }

  // Calls visit(pixel, x, y, u) for every third pixel of `scene`'s camera whose centre's ray meets
  // the square away from its edges, u the texture coordinate there; returns how many.
  template <typename Visit>
  static int visit_square_pixels(const Scene& scene, Visit visit) {
    const PinholeCamera camera = PinholeCamera::from(scene.camera);
    int visited = 0;
    for (int y = 0; y < scene.camera.height; y += 3) {
      for (int x = 0; x < scene.camera.width; x += 3) {
        const size_t pixel = size_t(y) * scene.camera.width + x;
        const Ray ray = camera.pixel_ray(pixel, 0.5f, 0.5f);
        const float t = -ray.origin.z / ray.direction.z;
        const float px = ray.origin.x + t * ray.direction.x;
        const float py = ray.origin.y + t * ray.direction.y;
        if (std::fabs(px) > 0.95f || std::fabs(py) > 0.95f) continue;
        visit(pixel, x, y, 0.5f * (px + 1.0f));
        ++visited;
      }
    }
    return visited;
  }

  // The scene with `settings` rendered for `passes`, and worst_error over its image; `report`, when
  // given, gets the render's report.
  double rendered_worst_error(const std::string& settings, uint32_t passes, int step, int& checked,
                              PassReport* report = nullptr) const {
    const Scene s = scene(settings);
    auto engine = engine_with(s);
    const absl::StatusOr<PassReport> rendered = engine->render(passes);
    EXPECT_TRUE(rendered.ok()) << rendered.status();
    if (report != nullptr && rendered.ok()) *report = *rendered;
    return worst_error(s, engine->image_linear(), step, checked);
  }

  // The largest relative error over every `step`-th pixel whose centre's ray meets the square
  // away from its edges; `checked` counts them.
  double worst_error(const Scene& scene, std::span<const float> image, int step,
                     int& checked) const {
    const PinholeCamera cam = PinholeCamera::from(scene.camera);
    double worst = 0;
    checked = 0;
    for (int y = step / 2; y < size; y += step) {
      for (int x = step / 2; x < size; x += step) {
        const Ray r = cam.ray_through(x + 0.5f, y + 0.5f);
        const Vec3f p = r.origin + r.direction * (-r.origin.z / r.direction.z);
        if (std::fabs(p.x) > 0.95f || std::fabs(p.y) > 0.95f) continue;
        const Vec3f d = light - p;
        const float dist2 = length_squared(d);
        const float expected = rho / kPi * intensity * (d.z / std::sqrt(dist2)) / dist2;
        const float got = image[4 * (y * size + x)];
        worst = std::max(worst, double(std::fabs(got - expected) / expected));
        ++checked;
      }
    }
    return worst;
  }
};

// A 6 x 6 diffuse floor of albedo rho at z = 0 under a square lamp of radiance le, half side
// `half`, at height h and facing down, seen from `eye` (looking at the origin) by a `width` x
// `height` camera; `settings` is the scene's settings object.
inline Scene floor_under_area_light(const std::string& settings, float rho, float le, float half,
                                    float h, Vec3f eye, int width, int height) {
  return parse_or_die(absl::StrFormat(R"({
    "camera": {"position": [%f, %f, %f], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 40,
               "width": %d, "height": %d},
    "settings": %s,
    "materials": {"floor": {"type": "diffuse", "albedo": [%f, %f, %f]},
                  "lamp": {"type": "emissive", "radiance": [%f, %f, %f]}},
    "shapes": [{"type": "quad", "material": "floor",
                "vertices": [[-3, -3, 0], [3, -3, 0], [3, 3, 0], [-3, 3, 0]]},
               {"type": "quad", "material": "lamp",
                "vertices": [[-%f, -%f, %f], [-%f, %f, %f], [%f, %f, %f], [%f, -%f, %f]]}]
  })",
                                      eye.x, eye.y, eye.z, width, height, settings, rho, rho, rho,
                                      le, le, le, half, half, h, half, half, h, half, half, h, half,
                                      half, h));
}

// Inside a closed diffuse sphere of albedo rho and radius R with a point light of power Phi at its
// centre, the radiance everywhere is rho Phi / (4 pi^2 R^2 (1 - rho)): direct light plus every
// interreflection.
struct InsideDiffuseSphere {
  float rho = 0.5f, radius = 1.0f, intensity = 2.0f;

  Scene scene(const std::string& settings) const {
    return parse_or_die(absl::StrFormat(R"({
      "camera": {"position": [0.1, 0.05, 0.0], "look_at": [0.1, 0.05, 1], "up": [0, 1, 0],
                 "fov": 90, "width": 64, "height": 64},
      "settings": %s,
      "materials": {"wall": {"type": "diffuse", "albedo": [%f, %f, %f]}},
      "lights": [{"type": "point", "position": [0, 0, 0], "intensity": [%f, %f, %f]}],
      "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": %f, "rings": 96,
                  "segments": 192, "material": "wall"}]
    })",
                                        settings, rho, rho, rho, intensity, intensity, intensity,
                                        radius));
  }
  double expected() const {
    const double phi = 4.0 * kPi * intensity;
    return rho * phi / (4 * kPi * kPi * radius * radius * (1 - rho));
  }
  // The image's mean green radiance.
  static double mean(std::span<const float> image) {
    double sum = 0;
    for (size_t i = 0; i < image.size(); i += 4) sum += image[i + 1];
    return sum / double(image.size() / 4);
  }
};

}  // namespace caustica
