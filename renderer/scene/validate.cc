#include "renderer/scene/validate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "renderer/scene/density_grid.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/status_util.h"

namespace caustica {
namespace {

std::string format_vec(Vec3f v) { return absl::StrFormat("(%g, %g, %g)", v.x, v.y, v.z); }

// Colours and intensities: finite, no negative channel, and at most `max` when given.
absl::Status check_color(absl::string_view field, Vec3f c, float max = INFINITY) {
  if (!is_finite(c)) return invalid_field(field, absl::StrCat(format_vec(c), " is not finite"));
  if (c.x < 0 || c.y < 0 || c.z < 0) {
    return invalid_field(field, absl::StrCat(format_vec(c), " has a negative channel"));
  }
  if (c.x > max || c.y > max || c.z > max) {
    return invalid_field(field, absl::StrCat(format_vec(c), " has a channel above ", max,
                                             " (a surface cannot reflect more than it receives)"));
  }
  return absl::OkStatus();
}

// Metalness and roughness: finite and in [0, 1].
absl::Status check_unit_interval(absl::string_view field, float value) {
  if (!(value >= 0 && value <= 1)) {
    return invalid_field(field, absl::StrCat(value, " is not a number in [0, 1]"));
  }
  return absl::OkStatus();
}

// For the integer fields: camera size and the settings counts.
absl::Status check_in_range(absl::string_view field, int64_t value, int64_t lo, int64_t hi) {
  if (!(value >= lo && value <= hi)) {
    return invalid_field(field, absl::StrCat(value, " is outside [", lo, ", ", hi, "]"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status check_tangent(const Vec4f& t) {
  const bool finite = is_finite(Vec3f(t.x, t.y, t.z)) && std::isfinite(t.w);
  if (finite && (t.w == 1.0f || t.w == -1.0f)) return absl::OkStatus();
  const std::string value = absl::StrFormat("(%g, %g, %g, %g)", t.x, t.y, t.z, t.w);
  if (!finite) return absl::InvalidArgumentError(absl::StrCat(value, " is not finite"));
  return absl::InvalidArgumentError(
      absl::StrCat(value, " has w = ", t.w, ", not 1 or -1 (the bitangent's sign)"));
}

// A mesh that encloses a medium must be closed, so that every ray that enters it leaves it: each
// edge, with its ends compared by position (shapes and files repeat corners), borders exactly two
// triangles, which run along it in opposite directions.
absl::Status check_closed(const Mesh& mesh, const std::string& field, const std::string& medium) {
  using Corner = std::array<float, 3>;
  auto corner = [&](uint32_t v) {
    const Vec3f p = mesh.positions[v];
    return Corner{p.x, p.y, p.z};
  };
  // Each undirected edge: how many triangles run along it from its smaller end, and how many back.
  std::map<std::pair<Corner, Corner>, std::pair<int, int>> edges;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const Corner a = corner(mesh.indices[3 * t + k]);
      const Corner b = corner(mesh.indices[3 * t + (k + 1) % 3]);
      if (a == b) continue;  // a degenerate triangle's collapsed edge
      if (a < b) {
        ++edges[{a, b}].first;
      } else {
        ++edges[{b, a}].second;
      }
    }
  }
  for (const auto& [edge, runs] : edges) {
    if (runs.first == 1 && runs.second == 1) continue;
    const auto& [a, b] = edge;
    const std::string where = absl::StrFormat("the edge from (%g, %g, %g) to (%g, %g, %g)", a[0],
                                              a[1], a[2], b[0], b[1], b[2]);
    if (runs.first + runs.second == 1) {
      return invalid_field(field, absl::StrCat("encloses medium '", medium, "' but is not closed: ",
                                               where, " borders one triangle"));
    }
    if (runs.first + runs.second == 2) {
      return invalid_field(field, absl::StrCat("encloses medium '", medium, "' but ", where,
                                               " joins two triangles facing opposite ways"));
    }
    return invalid_field(field,
                         absl::StrCat("encloses medium '", medium, "' but ", where, " borders ",
                                      runs.first + runs.second, " triangles, not two"));
  }
  return absl::OkStatus();
}

absl::Status validate_camera(const Camera& camera) {
  if (!is_finite(camera.position)) return invalid_field("camera.position", "is not finite");
  if (!is_finite(camera.look_at)) return invalid_field("camera.look_at", "is not finite");
  if (!is_finite(camera.up)) return invalid_field("camera.up", "is not finite");
  const Vec3f view = camera.look_at - camera.position;
  if (length_squared(view) == 0) {
    return invalid_field("camera.look_at",
                         absl::StrCat("equals camera.position ", format_vec(camera.position)));
  }
  if (length_squared(camera.up) == 0) return invalid_field("camera.up", "is the zero vector");
  if (length(cross(normalize(view), normalize(camera.up))) < 1e-6f) {
    return invalid_field("camera.up",
                         absl::StrCat(format_vec(camera.up), " is parallel to the view direction"));
  }
  if (!(camera.vertical_fov_deg > 0 && camera.vertical_fov_deg < 180)) {
    return invalid_field("camera.fov",
                         absl::StrCat(camera.vertical_fov_deg, " degrees is outside (0, 180)"));
  }
  SCENE_RETURN_IF_ERROR(check_in_range("camera.width", camera.width, 1, kMaxImageSide));
  return check_in_range("camera.height", camera.height, 1, kMaxImageSide);
}

absl::Status validate_settings(const RenderSettings& s) {
  SCENE_RETURN_IF_ERROR(
      check_in_range("settings.photons", s.photons_per_pass, 1, kMaxPhotonsPerPass));
  SCENE_RETURN_IF_ERROR(check_in_range("settings.k", s.k_nearest, 1, kMaxNearestPhotons));
  if (!(std::isfinite(s.max_radius) && s.max_radius >= 0)) {
    return invalid_field("settings.max_radius",
                         absl::StrCat(s.max_radius, " is not a finite number >= 0"));
  }
  if (!is_known_kind(s.kernel)) return invalid_field("settings.kernel", "is not a known kernel");
  if (!is_known_kind(s.integrator)) {
    return invalid_field("settings.integrator", "is not a known integrator");
  }
  if (!is_known_kind(s.estimator)) {
    return invalid_field("settings.estimator", "is not a known estimator");
  }
  if (s.integrator == Integrator::kPath && answers_batches_only(s.structure)) {
    return invalid_field(
        "settings.structure",
        absl::StrCat("the path integrator traces one ray at a time, and the structure ",
                     structure_kind_name(s.structure),
                     " answers batches only: choose another structure or integrator"));
  }
  if (!(s.sppm_alpha > 0 && s.sppm_alpha < 1)) {
    return invalid_field(
        "settings.sppm_alpha",
        absl::StrCat(s.sppm_alpha, " is not a number between 0 and 1 (exclusive)"));
  }
  if (!(s.vkde_spread >= 0 && s.vkde_spread <= kMaxVkdeSpread)) {
    return invalid_field("settings.vkde_spread",
                         absl::StrCat(s.vkde_spread, " is not a spread factor in [0, ",
                                      kMaxVkdeSpread, "] (0: automatic)"));
  }
  if (s.final_gather && s.integrator == Integrator::kPhoton && s.estimator != EstimatorKind::kKnn) {
    return invalid_field("settings.final_gather",
                         absl::StrCat("is for the knn estimator; ", kind_name(s.estimator),
                                      " gathers its indirect light itself"));
  }
  SCENE_RETURN_IF_ERROR(
      check_in_range("settings.final_gather_rays", s.final_gather_rays, 1, kMaxFinalGatherRays));
  SCENE_RETURN_IF_ERROR(
      check_in_range("settings.final_gather_seeds", s.final_gather_seeds, 0, kMaxFinalGatherSeeds));
  if (!is_known_kind(s.sppm_radius)) {
    return invalid_field("settings.sppm_radius", "is not a known radius rule");
  }
  SCENE_RETURN_IF_ERROR(check_in_range("settings.max_depth", s.max_depth, 0, kMaxDepth));
  SCENE_RETURN_IF_ERROR(
      check_in_range("settings.max_photon_bounces", s.max_photon_bounces, 0, kMaxPhotonBounces));
  SCENE_RETURN_IF_ERROR(check_in_range("settings.max_photon_specular_bounces",
                                       s.max_photon_specular_bounces, 0, kMaxPhotonBounces));
  SCENE_RETURN_IF_ERROR(
      check_in_range("settings.area_light_samples", s.area_light_samples, 1, kMaxAreaLightSamples));
  SCENE_RETURN_IF_ERROR(check_in_range("settings.passes", s.passes, 1, kMaxPasses));
  if (!std::ranges::any_of(kStructureKinds,
                           [&](StructureKind kind) { return kind == s.structure; })) {
    return invalid_field("settings.structure", "is not a known structure");
  }
  if (std::optional<std::string> problem = binned_sah_stages_problem(s.build.binned_sah)) {
    return invalid_field("settings.build.binned_sah_stages", *problem);
  }
  if (!is_known_kind(s.build.binned_sah.reorder)) {
    return invalid_field("settings.build.binned_sah_reorder", "is not a known binned-sah reorder");
  }
  if (!is_known_kind(s.build.kd_traversal)) {
    return invalid_field("settings.build.kd_traversal", "is not a known kd-tree traversal");
  }
  if (!is_known_kind(s.build.refit)) {
    return invalid_field("settings.build.refit", "is not a known refit policy");
  }
  if (std::optional<std::string> problem = refit_sah_bound_problem(s.build.refit_sah_bound)) {
    return invalid_field("settings.build.refit_sah_bound", *problem);
  }
  return absl::OkStatus();
}

namespace {

absl::Status validate_material(const Material& m, size_t textures) {
  const std::string field = absl::StrCat("materials.", m.name);
  for (const auto& [map, name] : m.maps()) {
    if (map->used() && map->texture >= textures) {
      return invalid_field(
          absl::StrCat(field, ".", name),
          absl::StrCat("is texture ", map->texture, ", but the scene has ", textures, " textures"));
    }
  }
  if (!(std::isfinite(m.normal_scale) && std::fabs(m.normal_scale) <= kMaxNormalScale)) {
    return invalid_field(absl::StrCat(field, ".normal_scale"),
                         absl::StrCat(m.normal_scale, " is not a number in [-", kMaxNormalScale,
                                      ", ", kMaxNormalScale, "]"));
  }
  if (!(std::isfinite(m.bump_scale) && std::fabs(m.bump_scale) <= kMaxBumpScale)) {
    return invalid_field(absl::StrCat(field, ".bump_scale"),
                         absl::StrCat(m.bump_scale, " is not a number in [-", kMaxBumpScale, ", ",
                                      kMaxBumpScale, "]"));
  }
  // The separate maps are packed into one at upload, sampled as one.
  for (const auto& [map, name] :
       {std::pair{&m.roughness_map, "roughness_map"}, std::pair{&m.metallic_map, "metallic_map"}}) {
    if (map->used() && m.metallic_roughness_map.used()) {
      return invalid_field(absl::StrCat(field, ".", name),
                           "excludes metallic_roughness_map: give the packed map or the separate "
                           "ones");
    }
  }
  if (m.roughness_map.used() && m.metallic_map.used() &&
      !m.roughness_map.samples_like(m.metallic_map)) {
    return invalid_field(absl::StrCat(field, ".metallic_map"),
                         "wraps or transforms its coordinates unlike roughness_map, with which "
                         "it is packed into one map");
  }
  if (m.alpha_mode > kLastAlphaMode) {
    return invalid_field(
        absl::StrCat(field, ".alpha_mode"),
        absl::StrCat(static_cast<uint32_t>(m.alpha_mode), " is not opaque, mask or blend"));
  }
  SCENE_RETURN_IF_ERROR(check_unit_interval(absl::StrCat(field, ".opacity"), m.opacity));
  // glTF bounds the cutoff below only: above 1 cuts the whole surface out.
  if (!(std::isfinite(m.alpha_cutoff) && m.alpha_cutoff >= 0)) {
    return invalid_field(absl::StrCat(field, ".alpha_cutoff"),
                         absl::StrCat(m.alpha_cutoff, " is not a number >= 0"));
  }
  // Any kind may emit; an emissive material only emits.
  SCENE_RETURN_IF_ERROR(check_color(absl::StrCat(field, ".radiance"), m.radiance));
  switch (m.type) {
    case MaterialType::kDiffuse:
      return check_color(absl::StrCat(field, ".albedo"), m.color, 1);
    case MaterialType::kMirror:
      return check_color(absl::StrCat(field, ".reflectance"), m.color, 1);
    case MaterialType::kDielectric:
      if (!(std::isfinite(m.ior) && m.ior > 0)) {
        return invalid_field(absl::StrCat(field, ".ior"),
                             absl::StrCat(m.ior, " is not a positive number"));
      }
      return check_unit_interval(absl::StrCat(field, ".roughness"), m.roughness);
    case MaterialType::kEmissive:
      return absl::OkStatus();
    case MaterialType::kMetallicRoughness:
      SCENE_RETURN_IF_ERROR(check_color(absl::StrCat(field, ".color"), m.color, 1));
      SCENE_RETURN_IF_ERROR(check_unit_interval(absl::StrCat(field, ".metallic"), m.metallic));
      return check_unit_interval(absl::StrCat(field, ".roughness"), m.roughness);
    case MaterialType::kPhong: {
      SCENE_RETURN_IF_ERROR(check_color(absl::StrCat(field, ".color"), m.color, 1));
      SCENE_RETURN_IF_ERROR(check_color(absl::StrCat(field, ".specular"), m.specular, 1));
      // The two lobes share what arrives: more than all of it in sum would create light.
      const Vec3f sum = m.color + m.specular;
      if (sum.x > 1 || sum.y > 1 || sum.z > 1) {
        return invalid_field(
            absl::StrCat(field, ".specular"),
            absl::StrCat(
                "color + specular = ", format_vec(sum),
                " has a channel above 1 (a surface cannot reflect more than it receives)"));
      }
      if (!(m.exponent > 0 && m.exponent <= kMaxPhongExponent)) {
        return invalid_field(
            absl::StrCat(field, ".exponent"),
            absl::StrCat(m.exponent, " is not a number in (0, ", kMaxPhongExponent, "]"));
      }
      return absl::OkStatus();
    }
  }
  static_assert(kLastMaterialType == MaterialType::kPhong,
                "validate_material checks every material type: add the new one above");
  return invalid_field(field, "has an unknown type");
}

absl::Status validate_medium(const Medium& m) {
  const std::string field = absl::StrCat("media.", m.name);
  if (m.type != MediumType::kHomogeneous && m.type != MediumType::kGrid)
    return invalid_field(field, "has an unknown type");
  SCENE_RETURN_IF_ERROR(check_color(absl::StrCat(field, ".absorption"), m.absorption));
  SCENE_RETURN_IF_ERROR(check_color(absl::StrCat(field, ".scattering"), m.scattering));
  if (!(std::isfinite(m.asymmetry) && std::fabs(m.asymmetry) < 1)) {
    return invalid_field(absl::StrCat(field, ".g"),
                         absl::StrCat(m.asymmetry, " is outside (-1, 1)"));
  }
  if (m.type != MediumType::kGrid) return absl::OkStatus();
  const std::string grid_field = absl::StrCat(field, ".grid");
  if (m.grid == nullptr) return invalid_field(grid_field, "is missing: a grid medium needs one");
  const double det = m.grid_to_scene.determinant();
  bool finite = std::isfinite(det);
  for (const auto& row : m.grid_to_scene.m)
    for (double x : row) finite = finite && std::isfinite(x);
  if (!finite || det == 0) {
    return invalid_field(absl::StrCat(field, ".transform"),
                         "is not an invertible map of finite numbers");
  }
  return check_density_grid(*m.grid, grid_field);
}

absl::Status validate_light(const Light& light, size_t index) {
  std::string field = absl::StrCat("lights[", index, "]");
  if (!light.name.empty()) absl::StrAppend(&field, " ('", light.name, "')");
  const bool directional = light.type == LightType::kDirectional;
  SCENE_RETURN_IF_ERROR(check_color(absl::StrCat(field, directional ? ".irradiance" : ".intensity"),
                                    light.intensity));
  if (light.type != LightType::kDirectional && !is_finite(light.position)) {
    return invalid_field(absl::StrCat(field, ".position"), "is not finite");
  }
  if (light.type != LightType::kPoint &&
      !(is_finite(light.direction) && length_squared(light.direction) > 0)) {
    return invalid_field(
        absl::StrCat(field, ".direction"),
        absl::StrCat(format_vec(light.direction), " is not a finite nonzero vector"));
  }
  if (light.type == LightType::kSpot) {
    if (!(light.outer_angle_deg > 0 && light.outer_angle_deg <= 180)) {
      return invalid_field(absl::StrCat(field, ".outer_angle"),
                           absl::StrCat(light.outer_angle_deg, " degrees is outside (0, 180]"));
    }
    if (!(light.inner_angle_deg >= 0 && light.inner_angle_deg <= light.outer_angle_deg)) {
      return invalid_field(
          absl::StrCat(field, ".inner_angle"),
          absl::StrCat(light.inner_angle_deg, " degrees is outside [0, outer_angle]"));
    }
  } else if (light.type != LightType::kPoint && light.type != LightType::kDirectional) {
    return invalid_field(field, "has an unknown type");
  }
  return absl::OkStatus();
}

// Whether a material lights the scene as loaded.
bool emits_now(const Material& m) { return !is_black(emitted_radiance(m)); }

// Zero area up to rounding: the cross product is tiny next to the edges that make it.
bool has_zero_area(Vec3f a, Vec3f b, Vec3f c) {
  const Vec3f e1 = b - a, e2 = c - a;
  const double twice_area = length(cross(e1, e2));
  return !(twice_area > 1e-7 * std::max(length_squared(e1), length_squared(e2)));
}

// Returns the number of triangles that emit light.
absl::StatusOr<size_t> validate_mesh(const Mesh& mesh, size_t index,
                                     const std::vector<Material>& materials,
                                     const std::vector<Medium>& media) {
  const std::string field =
      mesh.name.empty() ? absl::StrCat("meshes[", index, "]") : absl::StrCat("mesh ", mesh.name);
  if (mesh.indices.size() % 3 != 0) {
    return invalid_field(
        field, absl::StrCat("index count ", mesh.indices.size(), " is not a multiple of 3"));
  }
  const size_t triangles = mesh.triangle_count();
  if (triangles > kMaxTrianglesPerMesh) {
    return invalid_field(
        field, absl::StrCat(triangles, " triangles exceed the limit of ", kMaxTrianglesPerMesh));
  }
  if (mesh.material_ids.size() != triangles) {
    return invalid_field(field, absl::StrCat(triangles, " triangles but ", mesh.material_ids.size(),
                                             " material ids"));
  }
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) {
    return invalid_field(field, absl::StrCat(mesh.positions.size(), " vertices but ",
                                             mesh.normals.size(), " normals"));
  }
  if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size()) {
    return invalid_field(field, absl::StrCat(mesh.positions.size(), " vertices but ",
                                             mesh.uvs.size(), " texture coordinates"));
  }
  if (!mesh.tangents.empty() && mesh.tangents.size() != mesh.positions.size()) {
    return invalid_field(field, absl::StrCat(mesh.positions.size(), " vertices but ",
                                             mesh.tangents.size(), " tangents"));
  }
  if (!mesh.tangents.empty() && mesh.normals.empty()) {
    return invalid_field(field, "has tangents but no normals (a tangent frame needs both)");
  }
  for (size_t v = 0; v < mesh.uvs.size(); ++v) {
    if (!std::isfinite(mesh.uvs[v].x) || !std::isfinite(mesh.uvs[v].y)) {
      return invalid_field(field,
                           absl::StrCat("vertex ", v, " texture coordinates (", mesh.uvs[v].x, ", ",
                                        mesh.uvs[v].y, ") are not finite"));
    }
  }
  for (size_t v = 0; v < mesh.tangents.size(); ++v) {
    if (absl::Status s = check_tangent(mesh.tangents[v]); !s.ok()) {
      return invalid_field(field, absl::StrCat("vertex ", v, " tangent ", s.message()));
    }
  }
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    if (!is_finite(mesh.positions[v])) {
      return invalid_field(field, absl::StrCat("vertex ", v, " position ",
                                               format_vec(mesh.positions[v]), " is not finite"));
    }
  }
  for (size_t v = 0; v < mesh.normals.size(); ++v) {
    if (!is_finite(mesh.normals[v])) {
      return invalid_field(field, absl::StrCat("vertex ", v, " normal ",
                                               format_vec(mesh.normals[v]), " is not finite"));
    }
  }
  size_t emitters = 0;
  for (size_t t = 0; t < triangles; ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[3 * t + k];
      if (v >= mesh.positions.size()) {
        return invalid_field(
            field, absl::StrCat("triangle ", t, " refers to vertex ", v, ", but the mesh has ",
                                mesh.positions.size(), " vertices"));
      }
    }
    const uint32_t id = mesh.material_ids[t];
    if (id >= materials.size()) {
      return invalid_field(
          field, absl::StrCat("triangle ", t, " refers to material ", id, ", but the scene has ",
                              materials.size(), " materials"));
    }
    if (emits_now(materials[id])) {
      const uint32_t* tri = &mesh.indices[3 * t];
      const bool zero_area =
          has_zero_area(mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]);
      // A light's triangle must light; a model's emitting surface may have slivers, which emit
      // nothing.
      if (zero_area && materials[id].type != MaterialType::kEmissive) continue;
      if (zero_area) {
        return invalid_field(
            field, absl::StrCat("triangle ", t, " has zero area but emits light (material '",
                                materials[id].name, "')"));
      }
      ++emitters;
    }
  }
  if (mesh.interior_medium != kNoMedium) {
    if (mesh.interior_medium >= media.size()) {
      return invalid_field(field, absl::StrCat("encloses medium ", mesh.interior_medium,
                                               ", but the scene has ", media.size(), " media"));
    }
    SCENE_RETURN_IF_ERROR(check_closed(mesh, field, media[mesh.interior_medium].name));
  }
  return emitters;
}

}  // namespace

absl::Status validate_environment(const Environment& e, size_t textures) {
  if (!e.present) return absl::OkStatus();
  if (e.texture != kNoTexture && e.texture >= textures) {
    return invalid_field(
        "environment.map",
        absl::StrCat("is texture ", e.texture, ", but the scene has ", textures, " textures"));
  }
  SCENE_RETURN_IF_ERROR(check_color("environment.color", e.color));
  return validate_environment_change({e.intensity, e.rotation_deg});
}

absl::Status validate_environment_change(const EnvironmentChange& change) {
  if (change.intensity && !(*change.intensity >= 0 && std::isfinite(*change.intensity))) {
    return invalid_field("environment.intensity",
                         absl::StrCat(*change.intensity, " is not a finite number >= 0"));
  }
  if (change.rotation_deg && !std::isfinite(*change.rotation_deg)) {
    return invalid_field("environment.rotation",
                         absl::StrCat(*change.rotation_deg, " is not a finite angle"));
  }
  return absl::OkStatus();
}

absl::Status validate_lights(const std::vector<Light>& lights, size_t emitting_triangles,
                             bool environment) {
  for (size_t i = 0; i < lights.size(); ++i) SCENE_RETURN_IF_ERROR(validate_light(lights[i], i));
  if (lights.empty() && emitting_triangles == 0 && !environment) {
    return absl::InvalidArgumentError(
        "lights: the scene would have no light (it has no emissive triangles)");
  }
  return absl::OkStatus();
}

absl::Status validate_triangle_total(size_t triangles) {
  if (triangles > kMaxSceneTriangles) {
    return absl::InvalidArgumentError(
        absl::StrCat("scene has ", triangles, " triangles in all meshes, more than the limit of ",
                     kMaxSceneTriangles, " per scene"));
  }
  return absl::OkStatus();
}

absl::Status validate_scene(const Scene& scene) {
  SCENE_RETURN_IF_ERROR(validate_camera(scene.camera));
  SCENE_RETURN_IF_ERROR(validate_settings(scene.settings));
  if (scene.textures.size() > kMaxTextures) {
    return invalid_field(
        "textures", absl::StrCat(scene.textures.size(), " exceed the limit of ", kMaxTextures));
  }
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const TextureImage& t = scene.textures[i];
    if (t.encoded == nullptr && t.decoded == nullptr) {
      return invalid_field(absl::StrCat("textures[", i, "] '", t.name, "'"), "has no image");
    }
  }
  for (const Material& material : scene.materials) {
    SCENE_RETURN_IF_ERROR(validate_material(material, scene.textures.size()));
  }
  for (const Medium& medium : scene.media) SCENE_RETURN_IF_ERROR(validate_medium(medium));
  if (scene.medium != kNoMedium && scene.medium >= scene.media.size()) {
    return invalid_field("medium", absl::StrCat("is medium ", scene.medium, ", but the scene has ",
                                                scene.media.size(), " media"));
  }
  for (size_t i = 0; i < scene.lights.size(); ++i) {
    SCENE_RETURN_IF_ERROR(validate_light(scene.lights[i], i));
  }
  SCENE_RETURN_IF_ERROR(validate_environment(scene.environment, scene.textures.size()));
  // Before the meshes, whose checks would otherwise walk every one of too many triangles.
  SCENE_RETURN_IF_ERROR(validate_triangle_total(scene.triangle_count()));
  size_t emitting_triangles = 0;
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    SCENE_ASSIGN_OR_RETURN(const size_t emitters,
                           validate_mesh(scene.meshes[i], i, scene.materials, scene.media));
    emitting_triangles += emitters;
  }
  if (scene.triangle_count() == 0) {
    return absl::InvalidArgumentError("scene has no triangles (shapes is empty or all meshes are)");
  }
  if (scene.lights.empty() && emitting_triangles == 0 && !scene.environment.present) {
    return absl::InvalidArgumentError(
        "scene has no light: add an entry to lights, an environment or a shape with an emissive "
        "material");
  }
  return absl::OkStatus();
}

}  // namespace caustica
