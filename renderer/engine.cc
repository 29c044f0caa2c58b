#include "renderer/engine.h"

#include <chrono>
#include <optional>

#include "absl/status/status.h"
#include "renderer/photon/photon_map.h"
#include "renderer/photon/photon_tracer.h"
#include "renderer/render/camera.h"
#include "renderer/render/whitted.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/validate.h"

namespace caustica {
namespace {

double elapsed_ms(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

// Runs `fn`, turning a budget overrun anywhere below into RESOURCE_EXHAUSTED.
template <typename Fn>
absl::Status guarded(Fn&& fn) {
  try {
    return fn();
  } catch (const BudgetExceeded& e) {
    return absl::ResourceExhaustedError(e.what());
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError("out of memory");
  }
}

}  // namespace

struct Engine::State {
  std::unique_ptr<Backend> backend;
  Scene scene;
  std::optional<ResidentScene> resident;
  std::optional<Film> film;
  Epochs epochs;
  double last_build_ms = 0;
  size_t last_photon_map_bytes = 0;
};

Engine::Engine(std::unique_ptr<State> state) : state_(std::move(state)) {}
Engine::~Engine() = default;

absl::StatusOr<std::unique_ptr<Engine>> Engine::create(const EngineOptions& options) {
  auto state = std::make_unique<State>();
  switch (options.device) {
    case DeviceKind::kCpu:
      state->backend = make_cpu_backend(options.memory_budget_bytes);
      break;
    case DeviceKind::kCuda:
      return absl::UnimplementedError("this build has no CUDA backend");
  }
  return std::unique_ptr<Engine>(new Engine(std::move(state)));
}

absl::Status Engine::load(const Scene& scene) {
  if (absl::Status s = validate_scene(scene); !s.ok()) return s;
  return guarded([&]() -> absl::Status {
    State& st = *state_;
    st.resident.reset();
    st.film.reset();
    auto start = std::chrono::steady_clock::now();
    st.resident.emplace(ResidentScene::upload(*st.backend, scene));
    st.backend->synchronize();
    st.last_build_ms = elapsed_ms(start);
    st.scene = scene;
    st.film.emplace(*st.backend, scene.camera.width, scene.camera.height);
    ++st.epochs.geometry;
    ++st.epochs.lights;
    ++st.epochs.camera;
    ++st.epochs.settings;
    return absl::OkStatus();
  });
}

absl::Status Engine::set_lights(const std::vector<Light>& lights) {
  State& st = *state_;
  if (!st.resident) return absl::FailedPreconditionError("no scene loaded");
  Scene candidate = st.scene;
  candidate.lights = lights;
  if (absl::Status s = validate_scene(candidate); !s.ok()) return s;
  return guarded([&]() -> absl::Status {
    st.resident->set_lights(lights);
    st.scene.lights = lights;
    st.film->clear();
    ++st.epochs.lights;
    return absl::OkStatus();
  });
}

absl::Status Engine::set_camera(const Camera& camera) {
  State& st = *state_;
  if (!st.resident) return absl::FailedPreconditionError("no scene loaded");
  Scene candidate = st.scene;
  candidate.camera = camera;
  if (absl::Status s = validate_scene(candidate); !s.ok()) return s;
  return guarded([&]() -> absl::Status {
    if (camera.width != st.scene.camera.width || camera.height != st.scene.camera.height) {
      st.film.reset();
      st.film.emplace(*st.backend, camera.width, camera.height);
    } else {
      st.film->clear();
    }
    st.scene.camera = camera;
    ++st.epochs.camera;
    return absl::OkStatus();
  });
}

absl::Status Engine::set_settings(const RenderSettings& settings) {
  State& st = *state_;
  if (!st.resident) return absl::FailedPreconditionError("no scene loaded");
  Scene candidate = st.scene;
  candidate.settings = settings;
  if (absl::Status s = validate_scene(candidate); !s.ok()) return s;
  st.scene.settings = settings;
  st.film->clear();
  ++st.epochs.settings;
  return absl::OkStatus();
}

float Engine::max_radius() const {
  const State& st = *state_;
  if (st.scene.settings.max_radius > 0) return st.scene.settings.max_radius;
  return st.resident ? 0.05f * length(st.resident->bounds().extent()) : 0.0f;
}

absl::StatusOr<PassReport> Engine::render(uint32_t passes, const Progress& progress) {
  State& st = *state_;
  if (!st.resident) return absl::FailedPreconditionError("no scene loaded");
  PassReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    const RenderSettings& rs = st.scene.settings;
    const PinholeCamera camera = PinholeCamera::from(st.scene.camera);
    Backend& backend = *st.backend;
    for (uint32_t i = 0; i < passes; ++i) {
      const uint32_t pass = st.film->passes();
      auto t0 = std::chrono::steady_clock::now();
      TracedPhotons traced = trace_photons(
          backend, *st.resident, {rs.photons_per_pass, rs.max_photon_bounces, rs.seed, pass});
      backend.synchronize();
      report.timings.photon_trace_ms += elapsed_ms(t0);
      report.photons_emitted += traced.emitted;
      report.caustic_photons = traced.caustic.size();
      report.global_photons = traced.global.size();

      auto t1 = std::chrono::steady_clock::now();
      PhotonMap caustic_map = build_photon_map(backend, std::move(traced.caustic));
      PhotonMap global_map = build_photon_map(backend, std::move(traced.global));
      backend.synchronize();
      report.timings.photon_map_build_ms += elapsed_ms(t1);
      st.last_photon_map_bytes = caustic_map.bytes() + global_map.bytes();

      auto t2 = std::chrono::steady_clock::now();
      ShadingSettings shading{rs.k_nearest, max_radius(), rs.kernel, rs.max_depth,
                              rs.area_light_samples, rs.seed, pass};
      render_pass(backend, *st.resident, caustic_map, global_map, camera, shading, *st.film);
      backend.synchronize();
      report.timings.render_ms += elapsed_ms(t2);
      ++report.passes_rendered;
      if (progress) progress(i + 1, passes);
    }
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  report.total_passes = st.film->passes();
  return report;
}

std::vector<float> Engine::image_linear() { return state_->film->resolve_linear(); }
std::vector<Rgba8> Engine::image_srgb8(float exposure_stops) {
  return state_->film->resolve_srgb8(exposure_stops);
}
const Scene& Engine::scene() const { return state_->scene; }
const Epochs& Engine::epochs() const { return state_->epochs; }
DeviceInfo Engine::device_info() const { return state_->backend->info(); }
Backend& Engine::backend() { return *state_->backend; }

SceneStats Engine::scene_stats() const {
  const State& st = *state_;
  SceneStats s;
  if (!st.resident) return s;
  s.triangles = st.resident->triangle_count();
  s.structure_nodes = st.resident->bvh().node_count();
  s.structure_bytes = st.resident->bvh().bytes();
  s.photon_map_bytes = st.last_photon_map_bytes;
  s.lights = st.resident->view().light_count;
  s.last_structure_build_ms = st.last_build_ms;
  return s;
}

}  // namespace caustica
