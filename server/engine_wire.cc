#include "server/engine_wire.h"

#include "absl/strings/str_cat.h"
#include "proto/wire/scene_wire.h"

namespace caustica::server {

v1::Epochs encode_epochs(const Epochs& epochs) {
  v1::Epochs out;
  out.set_geometry(epochs.geometry);
  out.set_lights(epochs.lights);
  out.set_camera(epochs.camera);
  out.set_settings(epochs.settings);
  return out;
}

void add_timings(const StageTimings& timings, v1::StageTimings* out) {
  out->set_structure_build_ms(out->structure_build_ms() + timings.structure_build_ms);
  out->set_photon_trace_ms(out->photon_trace_ms() + timings.photon_trace_ms);
  out->set_photon_map_build_ms(out->photon_map_build_ms() + timings.photon_map_build_ms);
  out->set_render_ms(out->render_ms() + timings.render_ms);
}

v1::RebuildReport encode_rebuild(const RebuildReport& report) {
  v1::RebuildReport out;
  for (const std::string& what : report.rebuilt) out.add_rebuilt(what);
  add_timings(report.timings, out.mutable_timings());
  out.set_photons_emitted(report.photons_emitted);
  out.set_caustic_photons(report.caustic_photons);
  out.set_global_photons(report.global_photons);
  *out.mutable_epochs() = encode_epochs(report.epochs);
  return out;
}

void add_timings(const v1::StageTimings& t, v1::StageTimings* out) {
  out->set_structure_build_ms(out->structure_build_ms() + t.structure_build_ms());
  out->set_photon_trace_ms(out->photon_trace_ms() + t.photon_trace_ms());
  out->set_photon_map_build_ms(out->photon_map_build_ms() + t.photon_map_build_ms());
  out->set_render_ms(out->render_ms() + t.render_ms());
  out->set_resolve_ms(out->resolve_ms() + t.resolve_ms());
  out->set_queue_ms(out->queue_ms() + t.queue_ms());
}

void describe_geometry(const Scene& scene, v1::SceneInfo* info) {
  uint64_t vertices = 0;
  uint64_t emissive_triangles = 0;
  for (const Mesh& mesh : scene.meshes) {
    vertices += mesh.positions.size();
    for (uint32_t material : mesh.material_ids) {
      if (is_emitter(scene.materials[material])) ++emissive_triangles;
    }
  }
  info->set_vertices(vertices);
  info->set_meshes(static_cast<uint32_t>(scene.meshes.size()));
  info->clear_mesh_names();
  for (const Mesh& mesh : scene.meshes) info->add_mesh_names(mesh.name);
  info->set_materials(static_cast<uint32_t>(scene.materials.size()));
  info->set_area_lights(static_cast<uint32_t>(emissive_triangles));
  info->clear_textures();
  for (const TextureImage& texture : scene.textures) {
    v1::TextureInfo* t = info->add_textures();
    t->set_name(texture.name);
    if (texture.decoded == nullptr) continue;
    t->set_width(texture.decoded->width);
    t->set_height(texture.decoded->height);
    t->set_is_float(texture.decoded->is_float());
    t->set_decoded_bytes(texture.decoded->bytes());
  }
}

void describe_lights(const Scene& scene, v1::SceneInfo* info) {
  info->clear_light_list();
  for (const Light& light : scene.lights) *info->add_light_list() = wire::encode_light(light);
  info->clear_environment();
  if (scene.environment.present)
    *info->mutable_environment() = wire::encode_environment(scene.environment);
  info->clear_emitters();
  for (const Material& material : scene.materials) {
    if (is_emitter(material)) *info->add_emitters() = wire::encode_emitter(material);
  }
}

void describe_state(const Engine& engine, v1::SceneInfo* info) {
  const Scene& scene = engine.scene();
  const SceneStats stats = engine.scene_stats();
  info->set_triangles(stats.triangles);
  info->set_lights(static_cast<uint32_t>(scene.lights.size()));
  *info->mutable_camera() = wire::encode_camera(scene.camera);
  *info->mutable_settings() = wire::encode_settings(scene.settings);
  *info->mutable_epochs() = encode_epochs(engine.epochs());
  info->set_structure(structure_kind_name(stats.structure));
  info->set_structure_nodes(stats.structure_nodes);
  info->set_structure_bytes(stats.structure_bytes);
  info->set_structure_build_ms(stats.last_structure_build_ms);
  info->set_structure_sah_cost(stats.structure_sah_cost);
  info->set_structure_refits(stats.structure_refits);
  info->set_structure_built_sah_cost(stats.structure_built_sah_cost);
  info->set_photon_map_bytes(stats.photon_map_bytes);
  info->set_device_bytes(stats.device_bytes);
  info->set_passes(engine.film_passes());
}

namespace {

// The parts UpdateLightsRequest and Keyframe share.
template <typename Message>
absl::StatusOr<SceneChange> decode_light_change(const Message& m, const std::string& prefix) {
  SceneChange change;
  absl::StatusOr<std::vector<Light>> lights = wire::decode_lights(m.lights(), prefix + "lights");
  if (!lights.ok()) return lights.status();
  if (!m.keep_lights()) {
    change.lights = *std::move(lights);
  } else if (!lights->empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(prefix, "lights: must be empty with keep_lights, which keeps the lights"));
  }
  absl::StatusOr<std::vector<EmitterChange>> emitters =
      wire::decode_emitters(m.emitters(), prefix + "emitters");
  if (!emitters.ok()) return emitters.status();
  change.emitters = *std::move(emitters);
  if (m.has_environment_intensity()) change.environment.intensity = m.environment_intensity();
  if (m.has_environment_rotation_deg())
    change.environment.rotation_deg = m.environment_rotation_deg();
  return change;
}

}  // namespace

absl::StatusOr<SceneChange> decode_change(const v1::UpdateLightsRequest& request) {
  return decode_light_change(request, "");
}

absl::StatusOr<SceneChange> decode_change(const v1::Keyframe& keyframe, const std::string& prefix) {
  absl::StatusOr<SceneChange> change = decode_light_change(keyframe, prefix);
  if (!change.ok()) return change.status();
  absl::StatusOr<std::vector<MeshChange>> meshes =
      wire::decode_mesh_changes(keyframe.meshes(), prefix + "meshes");
  if (!meshes.ok()) return meshes.status();
  change->meshes = *std::move(meshes);
  return change;
}

}  // namespace caustica::server
