// light set SCENE: replaces the scene's lights (UpdateLights) and prints the rebuild report;
// light emit SCENE MATERIAL changes an area light's emission and light environment SCENE the
// environment's intensity or rotation the same way.
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "client/commands.h"
#include "client/light_json.h"
#include "client/result_output.h"
#include "renderer/scene/file_io.h"

namespace caustica::client {

absl::StatusOr<v1::Vec3> parse_vec3_flag(std::string_view flag, const std::string& text,
                                         bool allow_scalar) {
  const std::vector<std::string> parts = absl::StrSplit(text, ',');
  float v[3];
  bool ok = parts.size() == 3 || (allow_scalar && parts.size() == 1);
  for (size_t i = 0; ok && i < parts.size(); ++i) ok = absl::SimpleAtof(parts[i], &v[i]);
  if (!ok) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", absl::string_view(flag.data(), flag.size()), ": expected X,Y,Z",
                     allow_scalar ? " or one value" : "", ", got '", text, "'"));
  }
  if (parts.size() == 1) v[1] = v[2] = v[0];
  v1::Vec3 out;
  out.set_x(v[0]);
  out.set_y(v[1]);
  out.set_z(v[2]);
  return out;
}

namespace {

absl::StatusOr<v1::Light> light_from_flags(const LightSetOptions& o) {
  v1::Light light;
  light.set_name(o.name);
  const char* kind = !o.point.empty() ? "point" : !o.spot.empty() ? "spot" : "directional";
  if (o.intensity.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("--intensity: required for a ", kind, " light"));
  }
  absl::StatusOr<v1::Vec3> intensity = parse_vec3_flag("intensity", o.intensity, true);
  if (!intensity.ok()) return intensity.status();
  *light.mutable_intensity() = *intensity;
  if (!o.directional.empty()) {
    light.set_type(v1::Light::DIRECTIONAL);
    absl::StatusOr<v1::Vec3> direction = parse_vec3_flag("directional", o.directional, false);
    if (!direction.ok()) return direction.status();
    *light.mutable_direction() = *direction;
    return light;
  }
  const bool spot = !o.spot.empty();
  light.set_type(spot ? v1::Light::SPOT : v1::Light::POINT);
  absl::StatusOr<v1::Vec3> position =
      parse_vec3_flag(spot ? "spot" : "point", spot ? o.spot : o.point, false);
  if (!position.ok()) return position.status();
  *light.mutable_position() = *position;
  if (spot) {
    if (o.direction.empty()) return absl::InvalidArgumentError("--direction: required for --spot");
    absl::StatusOr<v1::Vec3> direction = parse_vec3_flag("direction", o.direction, false);
    if (!direction.ok()) return direction.status();
    *light.mutable_direction() = *direction;
    // The scene format's defaults for absent angles.
    const Light defaults;
    light.set_inner_angle_deg(o.inner_angle.value_or(defaults.inner_angle_deg));
    light.set_outer_angle_deg(o.outer_angle.value_or(defaults.outer_angle_deg));
  }
  return light;
}

}  // namespace

absl::StatusOr<std::vector<v1::Light>> lights_from_options(const LightSetOptions& o) {
  const int flag_lights = !o.point.empty() + !o.spot.empty() + !o.directional.empty();
  const int sources = (flag_lights > 0) + !o.file.empty() + o.none;
  if (sources != 1 || flag_lights > 1) {
    return absl::InvalidArgumentError(
        "give exactly one of --point, --spot, --directional, --file or --none");
  }
  if (o.none) return std::vector<v1::Light>();
  if (!o.file.empty()) {
    absl::StatusOr<std::string> text = read_file(o.file);
    if (!text.ok()) return text.status();
    return parse_lights_file(*text, o.file.string());
  }
  absl::StatusOr<v1::Light> light = light_from_flags(o);
  if (!light.ok()) return light.status();
  return std::vector<v1::Light>{*std::move(light)};
}

void print_rebuild(const GlobalOptions& global, const v1::RebuildReport& report,
                   std::ostream& out) {
  if (global.json) {
    print_json(out, to_json(report));
  } else {
    print_rebuild_report(out, report);
  }
}

absl::Status run_light_set(const GlobalOptions& global, const LightSetOptions& options,
                           std::ostream& out) {
  absl::StatusOr<std::vector<v1::Light>> lights = lights_from_options(options);
  if (!lights.ok()) return lights.status();
  v1::UpdateLightsRequest request;
  request.set_scene_id(options.scene);
  for (v1::Light& light : *lights) *request.add_lights() = std::move(light);
  if (options.expect_epoch) request.set_expected_lights_epoch(*options.expect_epoch);
  return send_update(global, request.scene_id(), &v1::RenderService::Stub::UpdateLights, request,
                     out);
}

absl::StatusOr<v1::UpdateLightsRequest> emit_request(const LightEmitOptions& options) {
  if (options.on && options.off) return absl::InvalidArgumentError("give --on or --off, not both");
  if (!options.on && !options.off && options.radiance.empty()) {
    return absl::InvalidArgumentError("give --radiance, --on or --off: nothing would change");
  }
  v1::UpdateLightsRequest request;
  request.set_scene_id(options.scene);
  request.set_keep_lights(true);
  v1::Emitter& emitter = *request.add_emitters();
  emitter.set_material(options.material);
  if (!options.radiance.empty()) {
    absl::StatusOr<v1::Vec3> radiance = parse_vec3_flag("radiance", options.radiance, true);
    if (!radiance.ok()) return radiance.status();
    *emitter.mutable_radiance() = *radiance;
  }
  if (options.on || options.off) emitter.set_off(options.off);
  if (options.expect_epoch) request.set_expected_lights_epoch(*options.expect_epoch);
  return request;
}

absl::Status run_light_emit(const GlobalOptions& global, const LightEmitOptions& options,
                            std::ostream& out) {
  absl::StatusOr<v1::UpdateLightsRequest> request = emit_request(options);
  if (!request.ok()) return request.status();
  return send_update(global, request->scene_id(), &v1::RenderService::Stub::UpdateLights, *request,
                     out);
}

absl::StatusOr<v1::UpdateLightsRequest> environment_request(
    const LightEnvironmentOptions& options) {
  if (!options.intensity && !options.rotation) {
    return absl::InvalidArgumentError("give --intensity or --rotation: nothing would change");
  }
  v1::UpdateLightsRequest request;
  request.set_scene_id(options.scene);
  request.set_keep_lights(true);
  if (options.intensity) request.set_environment_intensity(*options.intensity);
  if (options.rotation) request.set_environment_rotation_deg(*options.rotation);
  if (options.expect_epoch) request.set_expected_lights_epoch(*options.expect_epoch);
  return request;
}

absl::Status run_light_environment(const GlobalOptions& global,
                                   const LightEnvironmentOptions& options, std::ostream& out) {
  absl::StatusOr<v1::UpdateLightsRequest> request = environment_request(options);
  if (!request.ok()) return request.status();
  return send_update(global, request->scene_id(), &v1::RenderService::Stub::UpdateLights, *request,
                     out);
}

}  // namespace caustica::client
