// The benchmark suite behind caustica-bench. Each benchmark warms up, runs several times and
// reports the median (with min and max) as one JSON line: name, scene, device, value, unit.
#pragma once

#include <filesystem>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "renderer/parallel/buffer.h"
#include "renderer/photon/photon_map.h"
#include "renderer/render/camera.h"
#include "renderer/scene/scene.h"

namespace caustica {

struct BenchOptions {
  std::filesystem::path mesh;          // triangle mesh for the structure and ray benchmarks
  int copies = 1;                      // copy i translated by i * (0.25, 0.15, 0)
  std::filesystem::path photon_scene;  // scene for the photon and frame benchmarks
  std::vector<std::string> only;       // benchmark names to run; empty = all
  int runs = 5;
  int warmup = 1;
  int width = 1024, height = 1024;
  uint32_t photons = 1000000;
  uint32_t k = 64;
  // The frame benchmarks' estimator (--estimator); the convergence benchmark runs every one.
  EstimatorKind estimator = EstimatorKind::kKnn;
  bool final_gather = false;
  // Final gathering's rays a seed and seeds a pass; 0 keeps the scene's.
  uint32_t final_gather_rays = 0;
  uint32_t final_gather_seeds = 0;
  uint32_t photons_per_leaf = 0;  // 0: what the engine takes for the device and k
  std::string device = "cpu";     // serving benchmarks: the server's --device
  // The triangle structures to measure, each in turn (--structure NAME|all).
  std::vector<StructureKind> structures = {kDefaultStructure};
  // --structure-option NAME=VALUE, checked when parsed: over the scene file's settings.build, or
  // over the defaults for a mesh.
  std::vector<std::string> structure_options;
  // --kernels: after each measured benchmark, its per-launch times (one JSON line per launch name).
  bool kernels = false;
  // --ray-queues: the photon trace and the render pass through the ray queues for every structure.
  bool ray_queues = false;
  // --branch-survival: frame_render's cap on deep camera branches' survival (negative: the
  // renderer's own, kBranchSurvival).
  float branch_survival = -1.0f;
  // convergence: the path-traced reference's passes, and the most passes each integrator runs.
  uint32_t reference_passes = 4096;
  uint32_t convergence_passes = 256;
  // convergence: the runs measured, by name (convergence_run_names()); empty = every one.
  std::vector<std::string> convergence_runs;
  // frame_devices, animation_devices: the devices (GPU ordinals; on the CPU, as many CPU backends
  // as are listed) the multi-device engine runs on. Empty: every GPU, or two backends on the only
  // one.
  std::vector<int> devices;
  // seed_tables: the folder holding the bundled scenes (empty: the source tree's scenes/), the
  // Stanford dragon's mesh (empty: its rows are listed as unavailable), the frames of each flight
  // measured (0: all) and a divisor of every table's image sides and photons (1: the seeds' own).
  std::filesystem::path seed_scenes;
  std::filesystem::path dragon;
  int flight_frames = 0;
  int seed_reduce = 1;
};

// The photon scene (--scene) at the benchmark's size, photons per pass and k.
absl::StatusOr<Scene> load_photon_scene(const BenchOptions& options);
// "NAME WxH P photons k=K": the photon scene as the benchmark lines name it.
std::string photon_scene_label(const BenchOptions& options);
// The scene's lights at step i of a light animation: moved 10 units along x and back, so that
// every step is a real change.
std::vector<Light> moved_lights(const Scene& scene, int i);
// The scene's environment, where it has one, at step i of the same animation: turned 10 degrees
// and back.
EnvironmentChange turned_environment(const Scene& scene, int i);

// --final-gather-rays and --final-gather-seeds, where given, over the scene's settings.
void apply_final_gather_options(const BenchOptions& o, RenderSettings& settings);

// The convergence benchmark's runs (--convergence-run), in the order it measures them.
std::vector<std::string> convergence_run_names();

// The names run_benchmarks knows, in the order it runs them.
std::vector<std::string> benchmark_names();

// The camera of the ray benchmarks for a mesh with bounds `b`: outside the box, looking down -z at
// its centre.
Camera framing_camera(const Aabb& b, int width, int height);

// The camera's rays through pixel centres, in pixel order, queued in `rays`.
void queue_camera_rays(Backend& backend, const PinholeCamera& camera, Buffer<Ray>& rays);

// The backend --device names.
absl::StatusOr<std::shared_ptr<Backend>> make_bench_backend(const BenchOptions& o);

// The mesh (and its copies) as a scene: one diffuse material and a light above it. A scene file
// (.json) is loaded as it is.
absl::StatusOr<Scene> load_bench_mesh_scene(const BenchOptions& options);

absl::Status run_benchmarks(const BenchOptions& options, std::ostream& json_lines);

// Writes the ray benchmarks' camera for the mesh as "position look_at up vertical_fov_degrees",
// space-separated, so a peer renderer can be pointed the same way.
absl::Status print_ray_camera(const BenchOptions& options, std::ostream& out);

}  // namespace caustica
