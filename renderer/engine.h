// The renderer's facade, used by caustica-render, the benchmark and the server: one resident
// scene, change counters (epochs) per kind of input, and progressive rendering where every pass
// traces fresh photons, builds both photon maps and adds one sample per pixel to the film.
// Nothing here throws: allocation beyond the memory budget comes back as RESOURCE_EXHAUSTED.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "renderer/parallel/backend.h"
#include "renderer/photon/photon_map.h"
#include "renderer/render/film.h"
#include "renderer/render/whitted.h"
#include "renderer/scene/scene.h"

namespace caustica {

// "cpu", "cuda", or "auto": the GPU when this build has the CUDA backend and a GPU is present,
// else the CPU.
absl::StatusOr<DeviceKind> parse_device_kind(std::string_view name);
const char* device_kind_name(DeviceKind kind);

// A backend for `device` whose allocations count against `memory_budget_bytes`. A server makes
// one per device and shares it between the engines of the scenes there, so one budget covers
// them all. `ordinal`: which GPU (-1: the current one); ignored on the CPU.
absl::StatusOr<std::shared_ptr<Backend>> make_backend(DeviceKind device, size_t memory_budget_bytes,
                                                      int ordinal = -1);
// The GPUs this build and machine can use for `device` (0 for CUDA without a driver or GPU, or in
// a build without the CUDA backend); 1 for the CPU.
int device_count(DeviceKind device);

// OK when the engine renders `scene`'s participating media with `settings` (every scene without
// media), else UNIMPLEMENTED naming what does not trace through them (docs/media.md). Engine::load
// and set_settings refuse what this refuses.
absl::Status media_support(const Scene& scene, const RenderSettings& settings);

struct EngineOptions {
  DeviceKind device = DeviceKind::kCpu;
  size_t memory_budget_bytes = size_t(8) << 30;
  // When set, the engine allocates from this backend and ignores the two fields above. (Every
  // field has an initializer, so designated initializers may leave any out without a warning.)
  std::shared_ptr<Backend> backend = nullptr;
  // When it holds any, the engine works on all of them and ignores the three fields above: each
  // device holds the scene, traces its share of every pass's photons, builds the maps from all
  // of them and renders its bands of image rows (docs/multi-device.md). One gives what `backend`
  // gives; the same seed gives the same image on any number of devices.
  std::vector<std::shared_ptr<Backend>> backends = {};
  // Photons per leaf of the photon maps' hierarchy (photon/photon_map.h), a tuning knob; 0 takes
  // the estimator's own choice (for knn, photons_per_leaf_for in estimator/knn_gather.h).
  uint32_t photons_per_leaf = 0;
};

// A film size to change to with the settings; 0 keeps that side as it is.
struct ImageSize {
  uint32_t width = 0, height = 0;
};

// Change counters; each frame reports the epochs it reflects.
struct Epochs {
  uint64_t geometry = 0, lights = 0, camera = 0, settings = 0;
};

// Milliseconds spent per pipeline stage.
struct StageTimings {
  double structure_build_ms = 0;
  double photon_trace_ms = 0;
  double photon_map_build_ms = 0;
  double render_ms = 0;
  double total() const {
    return structure_build_ms + photon_trace_ms + photon_map_build_ms + render_ms;
  }
};

struct PassReport {
  StageTimings timings;  // summed over the passes rendered by this call
  uint32_t passes_rendered = 0;
  uint32_t total_passes = 0;  // in the film since the last change
  uint64_t photons_emitted = 0;
  uint64_t caustic_photons = 0;  // stored in the last pass
  uint64_t global_photons = 0;
};

// What a change (load, lights, camera, settings) rebuilt and what it cost.
struct RebuildReport {
  // "geometry", "lights", "photon_maps", "film"; a geometry change adds "structure" when the
  // structure was built anew and "structure_refit" when it was refitted (dacrt: neither).
  std::vector<std::string> rebuilt;
  StageTimings timings;
  uint64_t photons_emitted = 0;
  uint64_t caustic_photons = 0;  // stored
  uint64_t global_photons = 0;
  Epochs epochs;  // after the change
};

struct SceneStats {
  size_t triangles = 0;
  StructureKind structure = kDefaultStructure;
  size_t structure_nodes = 0;  // nodes of the triangle structure, in its own layout
  size_t structure_bytes = 0;
  double structure_sah_cost = 0;  // SAH cost of the structure, C_T = C_I = 1 (accel/structure.h)
  // Refits since it was built, and its SAH cost then (StructureStats).
  uint32_t structure_refits = 0;
  double structure_built_sah_cost = 0;
  size_t photon_map_bytes = 0;
  size_t device_bytes = 0;  // everything this engine holds: structure, lights, photon maps, film
  size_t lights = 0;
  double last_structure_build_ms = 0;
};

// What Engine::apply changes at once; unset or empty parts keep theirs.
struct SceneChange {
  std::optional<std::vector<Light>> lights;  // the complete list of non-geometry lights
  std::vector<EmitterChange> emitters;
  EnvironmentChange environment;
  std::vector<MeshChange> meshes;
};

// Not thread-safe: callers serialise every call on one engine. With several devices, each call
// works on all of them at once, from a thread per device, and returns when all are done.
// A change (set_lights, set_camera, set_settings, set_geometry) is all or nothing: refused by its
// checks or for memory on any device, it returns the error and leaves the scene, the epochs, the
// films and what a render draws as they were. What it replaces is built beside what is in use, so
// that for a while both take memory.
class Engine {
 public:
  static absl::StatusOr<std::unique_ptr<Engine>> create(const EngineOptions& options);
  ~Engine();

  // Replaces the scene: validates it, uploads it and builds the triangle structure.
  absl::StatusOr<RebuildReport> load(const Scene& scene);
  // Replaces the non-geometry lights, applies `emitters` to the emissive materials (area lights)
  // and `environment` to the environment (FAILED_PRECONDITION when it changes one the scene does
  // not have), then traces the photons of the next pass and builds both photon maps at once (the
  // light-change pipeline), so the next render only gathers.
  absl::StatusOr<RebuildReport> set_lights(const std::vector<Light>& lights,
                                           const std::vector<EmitterChange>& emitters = {},
                                           const EnvironmentChange& environment = {});
  // Restarts accumulation; a new resolution reallocates the film.
  absl::StatusOr<RebuildReport> set_camera(const Camera& camera);
  // Restarts accumulation; settings that change the photons re-trace them as set_lights does. A new
  // structure is built over the same triangles (a geometry change: its epoch moves, "geometry" is
  // reported) and the photons are traced through it. With a `size`, the film takes it as well
  // (the camera's epoch moves too): the settings and the size are checked together, and change
  // together or not at all.
  absl::StatusOr<RebuildReport> set_settings(const RenderSettings& settings,
                                             const ImageSize& size = {});

  // Moves and reshapes meshes, all changes at once: the geometry is uploaded again, the triangle
  // structure rebuilt (area lights follow their triangles), and the photons of the next pass
  // traced, as after a light change. The geometry and lights epochs move. NOT_FOUND for a mesh
  // the scene does not have; INVALID_ARGUMENT naming the change's field for the rest.
  absl::StatusOr<RebuildReport> set_geometry(std::span<const MeshChange> changes);
  // Lights, emitters, the environment and meshes changed together, as one keyframe of an
  // animation changes them: one structure build when meshes change, and one photon trace. The
  // epochs of what changed move; set_lights and set_geometry are its parts.
  absl::StatusOr<RebuildReport> apply(const SceneChange& change);
  // apply's checks without the change: what apply would refuse, as it would say it, judged on the
  // scene as it stands (an animation checks every keyframe before it plays the first).
  absl::Status check(const SceneChange& change) const;

  // The device bytes a geometry change (set_geometry, apply with meshes) builds beside what is in
  // use before it swaps, over every device: what a server checks against a tenant's share.
  size_t geometry_change_bytes() const;

  // What set_geometry changed since the scene was loaded, as changes that redo it on the scene
  // as loaded: per moved mesh, in scene order, its transform, and its vertices (and normals) where
  // they were replaced.
  std::vector<MeshChange> placements() const;

  using Progress = std::function<void(uint32_t done, uint32_t total)>;
  // Adds `passes` progressive passes to the film.
  absl::StatusOr<PassReport> render(uint32_t passes, const Progress& progress = {});

  // The film resolved into host memory the engine keeps (page-locked on a GPU, so that a frame
  // comes back by one direct copy), valid until the next image call or film change.
  std::span<const float> image_linear();  // RGBA float, top row first
  std::span<const Rgba8> image_srgb8(float exposure_stops = 0.0f);

  const Scene& scene() const;
  const Epochs& epochs() const;
  // Continues the change counters of a scene restored from storage, so that clients see the
  // epochs they were last told; call right after load().
  void restore_epochs(const Epochs& epochs);
  // Passes in the film since the last change (0 without a scene).
  uint32_t film_passes() const;
  SceneStats scene_stats() const;
  // The first device's, and every device's in the order they were given.
  DeviceInfo device_info() const;
  std::vector<DeviceInfo> devices() const;
  // The first device's backend, and every device's.
  Backend& backend();
  std::vector<Backend*> backends();
  // The shading of pass `pass` as render() runs it, from the scene's settings; with it a caller
  // can time the render pass alone on photon maps of its own.
  ShadingSettings shading(uint32_t pass) const;

 private:
  struct State;
  explicit Engine(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace caustica
