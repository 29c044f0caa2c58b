// Text and JSON renderings of results (see result_output.h).
#include "client/result_output.h"

#include <google/protobuf/util/json_util.h>

#include <string>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "proto/wire/scene_wire.h"
#include "renderer/accel/build_options.h"

namespace caustica::client {
namespace {

std::string vec3_text(const v1::Vec3& v) {
  return absl::StrFormat("(%g, %g, %g)", v.x(), v.y(), v.z());
}

// settings.build as --structure-option names it.
std::string build_text(const v1::BuildOptions& build) {
  v1::RenderSettings only_build;
  *only_build.mutable_build() = build;
  const absl::StatusOr<RenderSettings> settings =
      wire::apply_settings(only_build, RenderSettings{}, "settings");
  return settings.ok() ? build_options_text(settings->build)
                       : std::string(settings.status().message());
}

}  // namespace

nlohmann::json to_json(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  std::string text;
  if (!google::protobuf::util::MessageToJsonString(message, &text, options).ok()) return {};
  return nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
}

nlohmann::json frame_header_json(const v1::Frame& frame) {
  v1::Frame header = frame;
  header.clear_data();
  nlohmann::json json = to_json(header);
  json.erase("data");
  return json;
}

void print_json(std::ostream& out, const nlohmann::json& value) { out << value.dump() << "\n"; }

std::string timings_text(const v1::StageTimings& t) {
  return absl::StrFormat(
      "structure %.1f | photon trace %.1f | photon maps %.1f | render %.1f | resolve %.1f | "
      "queue %.1f",
      t.structure_build_ms(), t.photon_trace_ms(), t.photon_map_build_ms(), t.render_ms(),
      t.resolve_ms(), t.queue_ms());
}

std::string epochs_text(const v1::Epochs& e) {
  return absl::StrFormat("geometry %d, lights %d, camera %d, settings %d", e.geometry(), e.lights(),
                         e.camera(), e.settings());
}

std::string frame_text(const v1::Frame& f) {
  return absl::StrFormat("%dx%d, %d passes, %d photons emitted, lights epoch %d", f.width(),
                         f.height(), f.passes(), f.photons_emitted(), f.epochs().lights());
}

std::string mib_text(uint64_t bytes) { return absl::StrFormat("%.2f MiB", bytes / 1048576.0); }

std::string structure_text(const v1::SceneInfo& s) {
  return absl::StrFormat("%s, %d nodes, %s, SAH %.1f, built in %.1f ms", s.structure(),
                         s.structure_nodes(), mib_text(s.structure_bytes()), s.structure_sah_cost(),
                         s.structure_build_ms());
}

void print_rebuild_report(std::ostream& out, const v1::RebuildReport& r) {
  out << absl::StrFormat("rebuilt      %s\n",
                         r.rebuilt().empty() ? "nothing" : absl::StrJoin(r.rebuilt(), ", "));
  out << absl::StrFormat("photons      %d emitted; stored %d caustic, %d global\n",
                         r.photons_emitted(), r.caustic_photons(), r.global_photons());
  out << absl::StrFormat("time (ms)    %s\n", timings_text(r.timings()));
  out << absl::StrFormat("epochs       %s\n", epochs_text(r.epochs()));
}

void print_scene_info(std::ostream& out, const v1::SceneInfo& s) {
  const v1::Camera& c = s.camera();
  const v1::RenderSettings& rs = s.settings();
  out << absl::StrFormat("scene        %s '%s'\n", s.scene_id(), s.name());
  out << absl::StrFormat("geometry     %d triangles, %d vertices, %d meshes, %d materials\n",
                         s.triangles(), s.vertices(), s.meshes(), s.materials());
  out << absl::StrFormat("lights       %d lights, %d emissive triangles\n", s.lights(),
                         s.area_lights());
  if (s.has_environment()) {
    const v1::Environment& e = s.environment();
    const std::string map =
        e.texture() == 0 || int(e.texture()) > s.textures_size()
            ? std::string("a constant sky")
            : absl::StrFormat("map %s", s.textures(int(e.texture()) - 1).name());
    out << absl::StrFormat("environment  %s, colour %s, intensity %g, rotation %g degrees\n", map,
                           vec3_text(e.color()), e.intensity(), e.rotation_deg());
  }
  for (const std::string& mesh : s.mesh_names()) out << absl::StrFormat("mesh         %s\n", mesh);
  for (const v1::TextureInfo& t : s.textures()) {
    out << absl::StrFormat("texture      %s: %dx%d, %s, %s\n", t.name(), t.width(), t.height(),
                           t.is_float() ? "float" : "8-bit", mib_text(t.decoded_bytes()));
  }
  out << absl::StrFormat("camera       %dx%d, fov %g, at %s looking at %s\n", c.width(), c.height(),
                         c.vertical_fov_deg(), vec3_text(c.position()), vec3_text(c.look_at()));
  out << absl::StrFormat(
      "settings     %d photons per pass, k %d, max radius %g, kernel %s, max depth %d, photon "
      "bounces %d (%d specular in a row), area light samples %d, seed %d\n",
      rs.photons_per_pass(), rs.k_nearest(), rs.max_radius(), v1::DensityKernel_Name(rs.kernel()),
      rs.max_depth(), rs.max_photon_bounces(), rs.max_photon_specular_bounces(),
      rs.area_light_samples(), rs.seed());
  out << absl::StrFormat(
      "integrator   %s, estimator %s (sppm alpha %g, radius %s; vkde spread %s; final gather "
      "%s)\n",
      v1::Integrator_Name(rs.integrator()), v1::Estimator_Name(rs.estimator()), rs.sppm_alpha(),
      v1::SppmRadius_Name(rs.sppm_radius()),
      rs.vkde_spread() > 0 ? absl::StrFormat("%g", rs.vkde_spread()) : "auto",
      rs.final_gather() ? absl::StrFormat("on, %d rays a seed", rs.final_gather_rays()) : "off");
  out << absl::StrFormat("structure    %s\n", structure_text(s));
  out << absl::StrFormat("build        %s\n", build_text(rs.build()));
  out << absl::StrFormat("memory       structure %s; photon maps %s; device %s\n",
                         mib_text(s.structure_bytes()), mib_text(s.photon_map_bytes()),
                         mib_text(s.device_bytes()));
  out << absl::StrFormat("upload       %s in %.1f ms\n", mib_text(s.upload_bytes()), s.upload_ms());
  // Where the scene lives, once the server has more than the one device 0.
  if (s.devices_size() > 1 || (s.devices_size() == 1 && s.devices(0) != 0)) {
    out << absl::StrFormat("devices      %s\n", absl::StrJoin(s.devices(), ","));
  }
  out << absl::StrFormat("film         %d passes\n", s.passes());
  out << absl::StrFormat("epochs       %s\n", epochs_text(s.epochs()));
  if (s.has_last_rebuild()) {
    out << absl::StrFormat("last rebuild %s: %s ms\n",
                           absl::StrJoin(s.last_rebuild().rebuilt(), ", "),
                           timings_text(s.last_rebuild().timings()));
  }
}

void print_scene_table(std::ostream& out,
                       const google::protobuf::RepeatedPtrField<v1::SceneInfo>& scenes) {
  if (scenes.empty()) {
    out << "no scenes\n";
    return;
  }
  out << absl::StrFormat("%-24s %-20s %10s %6s %6s %9s %12s\n", "ID", "NAME", "TRIANGLES", "LIGHTS",
                         "PASSES", "SIZE", "DEVICE");
  for (const v1::SceneInfo& s : scenes) {
    out << absl::StrFormat("%-24s %-20s %10d %6d %6d %4dx%-4d %12s\n", s.scene_id(), s.name(),
                           s.triangles(), s.lights() + s.area_lights(), s.passes(),
                           s.camera().width(), s.camera().height(), mib_text(s.device_bytes()));
  }
}

void print_stats(std::ostream& out, const v1::Stats& s) {
  const v1::DeviceInfo& d = s.device();
  out << absl::StrFormat(
      "server       up %.1f s; %d requests, %d frames served, %d active streams\n", s.uptime_s(),
      s.requests_served(), s.frames_served(), s.active_streams());
  out << absl::StrFormat("device       %s: %s, %d compute units, %s\n", d.kind(), d.name(),
                         d.compute_units(), mib_text(d.memory_bytes()));
  out << absl::StrFormat("memory       %s used of %s budget, peak %s\n",
                         mib_text(s.memory_used_bytes()), mib_text(s.memory_budget_bytes()),
                         mib_text(s.memory_peak_bytes()));
  // A server on several devices: each one's share (a one-device server's is the line above).
  if (s.devices_size() > 1) {
    for (const v1::DeviceStats& each : s.devices()) {
      out << absl::StrFormat(
          "device %-5d %s %d: %s, %d compute units; %s used of %s, peak %s; %d scenes, %d "
          "waiting\n",
          each.index(), each.kind(), each.ordinal(), each.name(), each.compute_units(),
          mib_text(each.memory_used_bytes()), mib_text(each.memory_budget_bytes()),
          mib_text(each.memory_peak_bytes()), each.scenes(), each.queue_waiting());
    }
  }
  out << absl::StrFormat("scenes       %d of at most %d\n", s.scenes(), s.max_scenes());
  if (!s.latencies().empty()) {
    out << absl::StrFormat("latency (ms) %-24s %7s %9s %9s %9s %9s\n", "stage", "count", "p50",
                           "p90", "p99", "max");
    for (const v1::LatencySummary& l : s.latencies()) {
      out << absl::StrFormat("             %-24s %7d %9.2f %9.2f %9.2f %9.2f\n", l.stage(),
                             l.count(), l.p50_ms(), l.p90_ms(), l.p99_ms(), l.max_ms());
    }
  }
  if (s.scene_stats().empty()) return;
  print_scene_table(out, s.scene_stats());
  for (const v1::SceneInfo& scene : s.scene_stats()) {
    out << absl::StrFormat("structure    %s: %s\n", scene.scene_id(), structure_text(scene));
  }
  if (s.devices_size() > 1) {
    for (const v1::SceneInfo& scene : s.scene_stats()) {
      out << absl::StrFormat("placed       %s: device%s %s\n", scene.scene_id(),
                             scene.devices_size() == 1 ? "" : "s",
                             absl::StrJoin(scene.devices(), ","));
    }
  }
}

}  // namespace caustica::client
