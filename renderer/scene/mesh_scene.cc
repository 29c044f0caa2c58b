#include "renderer/scene/mesh_scene.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "renderer/scene/shapes.h"
#include "renderer/scene/status_util.h"
#include "renderer/scene/transform.h"
#include "renderer/scene/validate.h"

namespace caustica {
namespace {

constexpr float kDegreesToRadians = 3.14159265358979f / 180.0f;
constexpr float kFramingFovDeg = 40;
// How much larger than the bounding sphere the framed cone is, so the model does not touch the
// image's edges.
constexpr float kFramingMargin = 1.1f;
// The floor reaches this many bounding radii from the model's centre: far enough to catch the
// shadows of a light a few radii up, and to fill the lower part of the image.
constexpr float kFloorRadii = 20;

// 3D-printing formats put z up (the 3MF specification requires it; STL and AMF tools follow it),
// while the rest of the scene model, the framing and the floor assume y up.
bool is_z_up_format(const std::filesystem::path& path) {
  const std::string extension = absl::AsciiStrToLower(path.extension().string());
  return extension == ".stl" || extension == ".3mf" || extension == ".amf";
}

// Exposure: a point light of intensity I at distance d gives irradiance I / d^2; 2 lights a
// white diffuse surface facing it to a radiance of about 0.6, a well exposed mid-tone.
constexpr float kTargetIrradiance = 2;

// Rays from a bare model's centre, spread evenly over the sphere, that decide whether it is an
// interior (enclosure_of).
constexpr int kEnclosureRays = 32;
// An interior is seen through a wider lens than an object is framed with.
constexpr float kInteriorFovDeg = 60;

// The distance along `direction` from `origin` to triangle (a, b, c), and whether the ray meets
// its front face (the side (b - a) x (c - a) points to); t < 0 for a miss (Moller-Trumbore).
struct RayHit {
  double t = -1;
  bool front = false;
};
RayHit intersect(Vec3f origin, Vec3f direction, Vec3f a, Vec3f b, Vec3f c) {
  const Vec3f e1 = b - a, e2 = c - a;
  const Vec3f p = cross(direction, e2);
  const double det = dot(e1, p);
  if (std::fabs(det) < 1e-20) return {};
  const Vec3f s = origin - a;
  const double u = dot(s, p) / det;
  if (u < 0 || u > 1) return {};
  const Vec3f q = cross(s, e1);
  const double v = dot(direction, q) / det;
  if (v < 0 || u + v > 1) return {};
  const double t = dot(e2, q) / det;
  if (t <= 0) return {};
  return {t, dot(direction, cross(e1, e2)) < 0};
}

}  // namespace

Enclosure enclosure_of(const std::vector<Mesh>& meshes, Vec3f center) {
  Enclosure out;
  int hits = 0, front = 0;
  double distance = 0;
  for (int i = 0; i < kEnclosureRays; ++i) {
    // A Fibonacci sphere: even coverage without a preferred axis.
    const double z = 1 - (2 * i + 1) / double(kEnclosureRays);
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    const double phi = i * 2.399963229728653;  // the golden angle
    const Vec3f d(float(r * std::cos(phi)), float(z), float(r * std::sin(phi)));
    RayHit nearest;
    for (const Mesh& mesh : meshes) {
      for (size_t t = 0; t < mesh.triangle_count(); ++t) {
        const uint32_t* idx = &mesh.indices[3 * t];
        const RayHit hit = intersect(center, d, mesh.positions[idx[0]], mesh.positions[idx[1]],
                                     mesh.positions[idx[2]]);
        if (hit.t > 0 && (nearest.t < 0 || hit.t < nearest.t)) nearest = hit;
      }
    }
    if (nearest.t < 0) continue;
    ++hits;
    front += nearest.front;
    distance += nearest.t;
    const float rise = float(nearest.t * d.y);
    if (d.y > 0.9f && (out.above < 0 || rise < out.above)) out.above = rise;
  }
  out.encloses = 2 * hits > kEnclosureRays && 2 * front > hits;
  out.mean_distance = hits > 0 ? float(distance / hits) : 0;
  return out;
}

Bounds mesh_bounds(const std::vector<Mesh>& meshes) {
  Bounds bounds;
  for (const Mesh& mesh : meshes) {
    for (const Vec3f& p : mesh.positions) {
      if (!is_finite(p)) continue;  // validation names such vertices
      if (bounds.empty()) {
        bounds.lo = bounds.hi = p;
      } else {
        bounds.lo = min(bounds.lo, p);
        bounds.hi = max(bounds.hi, p);
      }
    }
  }
  return bounds;
}

Camera frame_bounds(const Bounds& bounds, const Camera& image) {
  Camera camera = image;
  const Vec3f center = bounds.center();
  const float radius = std::max(0.5f * length(bounds.size()), 1e-6f);
  const float aspect = static_cast<float>(image.width) / static_cast<float>(image.height);
  const float half_vertical = 0.5f * kFramingFovDeg * kDegreesToRadians;
  const float half_horizontal = std::atan(std::tan(half_vertical) * aspect);
  // A sphere of radius r seen from distance D fills a cone of half-angle asin(r / D); it fits the
  // image when that cone fits the narrower of its two half-angles.
  const float half_angle = std::min(half_vertical, half_horizontal);
  const float distance = kFramingMargin * radius / std::sin(half_angle);
  const Vec3f from_front_above = normalize(Vec3f(0.35f, 0.5f, 1.0f));
  camera.position = center + from_front_above * distance;
  camera.look_at = center;
  camera.up = {0, 1, 0};
  camera.vertical_fov_deg = kFramingFovDeg;
  return camera;
}

absl::StatusOr<Scene> scene_around_mesh_file(MeshFile file, std::string_view source_name, bool z_up,
                                             std::vector<std::string>* warnings) {
  const absl::string_view source(source_name.data(), source_name.size());
  if (warnings != nullptr) {
    warnings->insert(warnings->end(), file.warnings.begin(), file.warnings.end());
  }
  if (z_up) {
    // (x, y, z) -> (x, z, -y): the file's up axis becomes ours, and its front (-y) faces +z.
    const Affine turn = rotation_x_deg(-90);
    for (Mesh& mesh : file.meshes) transform_mesh(turn, &mesh);
    for (Light& light : file.lights) transform_light(turn, &light);
    for (Camera& camera : file.cameras) {
      camera.position = turn.apply_to_point(camera.position);
      camera.look_at = turn.apply_to_point(camera.look_at);
      camera.up = turn.apply_to_vector(camera.up);
    }
  }
  Scene scene;
  scene.materials = std::move(file.materials);
  scene.textures = std::move(file.textures);
  scene.media = std::move(file.media);
  // Triangles the file leaves without a material (PLY, OBJ without MTL) get a light grey.
  uint32_t default_material = kNoMaterial;
  for (Mesh& mesh : file.meshes) {
    for (uint32_t& id : mesh.material_ids) {
      if (id != kNoMaterial) continue;
      if (default_material == kNoMaterial) {
        default_material = static_cast<uint32_t>(scene.materials.size());
        Material grey;
        grey.name = "default";
        scene.materials.push_back(grey);
      }
      id = default_material;
    }
  }
  bool emits = false;
  for (const Mesh& mesh : file.meshes) {
    for (const uint32_t id : mesh.material_ids) {
      emits |= id < scene.materials.size() && !is_black(emitted_radiance(scene.materials[id]));
    }
  }

  const Bounds bounds = mesh_bounds(file.meshes);
  if (bounds.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(source, ": the file has no vertices"));
  }
  const float radius = 0.5f * length(bounds.size());
  if (!(radius > 0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        source, ": the model has no extent (all vertices at one point), nothing to frame"));
  }
  if (!std::isfinite(radius)) {
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": the model's bounds are too large to frame in single precision"));
  }
  const Vec3f center = bounds.center();
  // A building or a room without a camera of its own is seen from inside, lit from inside.
  const Enclosure enclosure =
      file.cameras.empty() ? enclosure_of(file.meshes, center) : Enclosure{};

  scene.meshes = std::move(file.meshes);
  // The floor sits a hair under the model, so that a model standing on its lowest point does not
  // share that plane with the floor.
  if (!enclosure.encloses) {
    Material floor_material;
    floor_material.name = "floor";
    floor_material.color = {0.6f, 0.6f, 0.6f};
    const uint32_t floor_id = static_cast<uint32_t>(scene.materials.size());
    scene.materials.push_back(floor_material);
    const float y = bounds.lo.y - 1e-3f * radius;
    const float s = kFloorRadii * radius;
    Mesh floor =
        make_quad({Vec3f(center.x - s, y, center.z - s), Vec3f(center.x - s, y, center.z + s),
                   Vec3f(center.x + s, y, center.z + s), Vec3f(center.x + s, y, center.z - s)});
    floor.name = "floor";
    floor.material_ids.assign(floor.triangle_count(), floor_id);
    scene.meshes.push_back(std::move(floor));
  }

  if (!file.cameras.empty()) {
    scene.camera = file.cameras.front();
    if (file.cameras.size() > 1 && warnings != nullptr) {
      warnings->push_back(
          absl::StrCat(source, ": ", file.cameras.size(), " cameras; rendering through the first"));
    }
  } else if (enclosure.encloses) {
    // From the centre along the longer horizontal axis.
    const Vec3f size = bounds.size();
    scene.camera.position = center;
    scene.camera.look_at = center + (size.x >= size.z ? Vec3f(1, 0, 0) : Vec3f(0, 0, 1));
    scene.camera.up = {0, 1, 0};
    scene.camera.vertical_fov_deg = kInteriorFovDeg;
    if (warnings != nullptr) {
      // Says which light the view has: one added above the camera only where the file brings none.
      const char* lit = !file.lights.empty() ? "lit by the file's own lights"
                        : emits              ? "lit by the file's emitting surfaces alone"
                                             : "with a light above it";
      warnings->push_back(
          absl::StrCat(source, ": the model encloses its centre; seen from there, ", lit));
    }
  } else {
    scene.camera = frame_bounds(bounds, Camera{});
  }

  scene.lights = std::move(file.lights);
  if (scene.lights.empty() && !emits && enclosure.encloses) {
    // Halfway from the camera to what is above it, as bright at the walls' mean distance as the
    // light of a model is at the model.
    Light light;
    light.name = "default light";
    light.type = LightType::kPoint;
    const float half_height = 0.5f * bounds.size().y;
    const float rise = enclosure.above > 0 ? 0.5f * enclosure.above : 0.5f * half_height;
    light.position = center + Vec3f(0, rise, 0);
    const float distance = std::max(enclosure.mean_distance, 1e-3f * radius);
    light.intensity = Vec3f(kTargetIrradiance * distance * distance);
    scene.lights.push_back(light);
  } else if (scene.lights.empty() && !emits) {
    // Above the model, a little to the left and in front, so that its shadow falls behind it
    // onto the visible floor; three bounding radii away from the centre.
    Light light;
    light.name = "default light";
    light.type = LightType::kPoint;
    const float distance = 3 * radius;
    light.position = center + normalize(Vec3f(-0.4f, 1.0f, 0.6f)) * distance;
    light.intensity = Vec3f(kTargetIrradiance * distance * distance);
    scene.lights.push_back(light);
  }
  SCENE_RETURN_IF_ERROR(annotate(validate_scene(scene), source));
  return scene;
}

absl::StatusOr<Scene> load_mesh_scene(const std::filesystem::path& path,
                                      std::vector<std::string>* warnings) {
  SCENE_ASSIGN_OR_RETURN(MeshFile file, load_mesh_file(path));
  return scene_around_mesh_file(std::move(file), path.string(), is_z_up_format(path), warnings);
}

}  // namespace caustica
