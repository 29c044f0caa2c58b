// The scene model (renderer/scene/scene.h) in its wire form (proto/caustica/v1/scene.proto) and
// back. The client encodes a loaded scene into a header and mesh chunks; the server reassembles
// the chunks, checking each as it arrives, and validates the result like a scene file. Shared so
// both sides agree byte for byte on chunk layout and checksums.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "caustica/v1/scene.pb.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/scene/scene.h"

namespace caustica::wire {

// Largest `data` of one MeshChunk.
inline constexpr size_t kMaxChunkBytes = size_t{1} << 20;

// CRC-32 (IEEE) of `bytes`, as MeshChunk.crc32 carries it.
uint32_t chunk_crc32(std::string_view bytes);

// --- scene model -> wire ---
v1::Vec3 encode_vec3(const Vec3f& v);
v1::Material encode_material(const Material& m);
// An emissive material's emission as SceneInfo lists it.
v1::Emitter encode_emitter(const Material& m);
// UpdateLights' emitters: names non-empty, radiance (when given) finite and >= 0 per channel, and
// each one changing something; whether the material exists is the engine's to check.
absl::StatusOr<std::vector<EmitterChange>> decode_emitters(
    const google::protobuf::RepeatedPtrField<v1::Emitter>& emitters, std::string_view field);
v1::Light encode_light(const Light& light);
v1::Camera encode_camera(const Camera& camera);
v1::Environment encode_environment(const Environment& environment);
// `textures`: how many the scene has, which the environment's map must be one of.
absl::StatusOr<Environment> decode_environment(const v1::Environment& environment, size_t textures);
v1::RenderSettings encode_settings(const RenderSettings& settings);  // every field set
v1::Structure encode_structure(StructureKind kind);
v1::Integrator encode_integrator(Integrator integrator);
v1::Estimator encode_estimator(EstimatorKind estimator);
v1::SceneHeader encode_scene_header(const Scene& scene, const std::string& name);
v1::MeshUpdate encode_mesh_change(const MeshChange& change);
// Bytes the mesh and grid chunks of `scene` carry in total.
size_t upload_bytes(const Scene& scene);
// Fills `chunk` with each piece of one array of one mesh (its raw bytes, `bytes`), whole
// elements of at most `max_chunk_bytes`, and calls `emit` after each; stops early, returning
// false, when `emit` returns false.
bool for_each_array_chunk(uint32_t mesh, v1::MeshChunk::Array array, std::string_view bytes,
                          size_t max_chunk_bytes, v1::MeshChunk& chunk,
                          const std::function<bool()>& emit);
// Calls `emit` with every chunk after the header: the mesh chunks mesh by mesh and array by
// array, then each grid medium's grid chunks, then each texture's file, each at most
// `max_chunk_bytes` of data. Stops early, returning false, when `emit` returns false.
bool for_each_chunk(const Scene& scene, size_t max_chunk_bytes,
                    const std::function<bool(v1::SceneChunk& chunk)>& emit);

// --- wire -> scene model ---
// `field` is the path reported in errors, e.g. "lights[2]" or "keyframes[4].lights[0]".
absl::StatusOr<Vec3f> decode_vec3(const v1::Vec3& v, std::string_view field);
absl::StatusOr<Light> decode_light(const v1::Light& light, std::string_view field);
absl::StatusOr<std::vector<Light>> decode_lights(
    const google::protobuf::RepeatedPtrField<v1::Light>& lights, std::string_view field);
absl::StatusOr<Camera> decode_camera(const v1::Camera& camera, std::string_view field);
// A camera whose size the message does not give (a keyframe's): its width and height are not read
// and the camera takes `width` x `height`.
absl::StatusOr<Camera> decode_camera_at(const v1::Camera& camera, std::string_view field, int width,
                                        int height);
// nullopt for STRUCTURE_UNSPECIFIED and for values this build does not know.
std::optional<StructureKind> decode_structure(v1::Structure structure);
// UpdateGeometry's changes: names non-empty, transforms of 12 finite numbers, vertex arrays whole
// (three numbers each) and finite; whether the mesh exists and the counts fit it is the
// engine's to check.
absl::StatusOr<std::vector<MeshChange>> decode_mesh_changes(
    const google::protobuf::RepeatedPtrField<v1::MeshUpdate>& meshes, std::string_view field);
// Applies the fields set in `settings` on top of `current`.
absl::StatusOr<RenderSettings> apply_settings(const v1::RenderSettings& settings,
                                              const RenderSettings& current,
                                              std::string_view field);

// Rebuilds a Scene from an upload stream. Every add() checks the chunk on its own (order,
// offsets, sizes, checksum, indices in range, finite numbers) so a bad stream is refused at the
// first bad chunk with INVALID_ARGUMENT naming it; finish() checks that every declared array
// arrived whole. The scene-wide rules (validate_scene) are left to whoever uses the scene:
// Engine::load checks them, so an upload is not validated twice. Sizes are checked against
// scene_limits.h before any array is allocated (RESOURCE_EXHAUSTED beyond them).
// What a MeshHeader declares, as the assembler checks chunks against it.
struct MeshHeaderCounts {
  uint64_t vertices = 0;
  uint64_t triangles = 0;
  bool has_normals = false;
  bool has_texcoords = false;
  bool has_tangents = false;
  bool per_triangle_materials = false;
  uint32_t material = 0;  // the whole mesh's, without per-triangle materials
};

class SceneAssembler {
 public:
  absl::Status add(const v1::SceneChunk& chunk);
  absl::StatusOr<Scene> finish();

  bool has_header() const { return has_header_; }
  const std::string& name() const { return name_; }
  size_t chunks_received() const { return chunks_; }
  size_t bytes_received() const { return bytes_received_; }
  // Mesh, grid and texture bytes the header announced (what the scene will hold on the host before
  // upload).
  size_t bytes_declared() const { return bytes_declared_; }

 private:
  absl::Status add_header(const v1::SceneHeader& header);
  // A medium reference of the header (1 + index, 0 for none) as an index or kNoMedium.
  absl::StatusOr<uint32_t> decode_medium_ref(uint32_t value, const std::string& field) const;
  absl::Status add_mesh_chunk(const v1::MeshChunk& chunk);
  // A GRID medium's grid size (0 for others), its placement and source copied into `m`.
  absl::StatusOr<uint64_t> decode_grid_header(const v1::Medium& in, const std::string& field,
                                              Medium* m) const;
  absl::Status add_grid_chunk(const v1::GridChunk& chunk);
  absl::Status add_texture_chunk(const v1::TextureChunk& chunk);

  struct MeshProgress {
    std::array<size_t, v1::MeshChunk::Array_ARRAYSIZE> received{};  // bytes, by MeshChunk::Array
  };
  bool has_header_ = false;
  std::string name_;
  Scene scene_;
  std::vector<MeshHeaderCounts> counts_;
  std::vector<MeshProgress> progress_;
  // Per medium: grid bytes declared and received, and the buffer they arrive in.
  std::vector<uint64_t> grid_declared_;
  std::vector<uint64_t> grid_received_;
  std::vector<std::shared_ptr<AlignedBytes>> grids_;
  // Per texture: file bytes declared and received, and the string they arrive in.
  std::vector<uint64_t> texture_declared_;
  std::vector<uint64_t> texture_received_;
  std::vector<std::shared_ptr<std::string>> texture_files_;
  size_t chunks_ = 0;
  size_t bytes_received_ = 0;
  size_t bytes_declared_ = 0;
};

}  // namespace caustica::wire
