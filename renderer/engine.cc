#include "renderer/engine.h"

#include <chrono>
#include <optional>
#include <stdexcept>
#include <tuple>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "renderer/estimator/estimator.h"
#include "renderer/photon/photon_map.h"
#include "renderer/photon/photon_tracer.h"
#include "renderer/render/camera.h"
#include "renderer/render/path_tracer.h"
#include "renderer/render/whitted.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/emitters.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/validate.h"

#if defined(CAUSTICA_WITH_CUDA)
#include "renderer/parallel/cuda/cuda_backend.h"
#endif

namespace caustica {
namespace {

double elapsed_ms(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since)
      .count();
}

// Runs `fn`, turning a budget overrun anywhere below into RESOURCE_EXHAUSTED, a device failure
// (a CUDA error) into INTERNAL, and input a builder cannot take (a structure's own limits, such
// as sibling-pair's triangle count) into INVALID_ARGUMENT.
template <typename Fn>
absl::Status guarded(Fn&& fn) {
  try {
    return fn();
  } catch (const BudgetExceeded& e) {
    return absl::ResourceExhaustedError(e.what());
  } catch (const OutOfDeviceMemory& e) {
    return absl::ResourceExhaustedError(e.what());
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError("out of memory");
  } catch (const DeviceError& e) {
    return absl::InternalError(e.what());
  } catch (const std::invalid_argument& e) {
    // A structure refusing its input (too many triangles for its layout) or an integrator (the
    // path integrator, a batch-only structure), or a setting read from
    // the environment (CAUSTICA_KD_TRAVERSAL, CAUSTICA_BINNED_SAH_STAGES) that names nothing.
    return absl::InvalidArgumentError(e.what());
  }
}

#if defined(CAUSTICA_WITH_CUDA)
constexpr bool kBuiltWithCuda = true;
#else
constexpr bool kBuiltWithCuda = false;
bool cuda_device_available() { return false; }  // no backend, so never a device for it
#endif

absl::Status no_cuda_backend() {
  return absl::FailedPreconditionError(
      "this build has no CUDA backend (configure with -DCAUSTICA_CUDA=ON, e.g. the cuda preset)");
}

}  // namespace

// Participating media render with the path integrator and the beam radiance estimate of the knn
// and vkde estimators; sppm would render a scene with media as if they were not there.
absl::Status media_support(const Scene& scene, const RenderSettings& rs) {
  if (scene.media.empty()) return absl::OkStatus();
  if (rs.structure == StructureKind::kDacrt) {
    return absl::UnimplementedError(
        "media: the dacrt structure answers ray batches only, and the ray queues do not trace "
        "through participating media yet; choose another structure");
  }
  if (rs.integrator == Integrator::kPath) return absl::OkStatus();
  if (rs.estimator != EstimatorKind::kKnn && rs.estimator != EstimatorKind::kVkde) {
    return absl::UnimplementedError(absl::StrCat(
        "media: the ", estimator_kind_name(rs.estimator),
        " estimator does not render participating media yet; the knn and vkde estimators and the "
        "path integrator do"));
  }
  if (rs.final_gather) {
    return absl::UnimplementedError(
        "media: final gathering does not trace through participating media yet; turn "
        "final_gather off, or render with the path integrator");
  }
  return absl::OkStatus();
}

// The estimator the settings name, with the engine's leaf-size knob.
EstimatorOptions estimator_options(const RenderSettings& rs, uint32_t photons_per_leaf) {
  return {rs.estimator,    rs.k_nearest,         photons_per_leaf,
          rs.sppm_alpha,   rs.sppm_radius,       rs.vkde_spread,
          rs.final_gather, rs.final_gather_rays, rs.final_gather_seeds};
}

bool same_estimator(const RenderSettings& a, const RenderSettings& b) {
  return a.estimator == b.estimator && a.sppm_alpha == b.sppm_alpha &&
         a.sppm_radius == b.sppm_radius && a.vkde_spread == b.vkde_spread &&
         a.final_gather == b.final_gather && a.final_gather_rays == b.final_gather_rays &&
         a.final_gather_seeds == b.final_gather_seeds;
}

struct Engine::State {
  std::shared_ptr<Backend> backend;
  Scene scene;
  std::optional<ResidentScene> resident;
  std::optional<Film> film;
  // Owns the photon maps (those traced ahead by a light change serve the pass they were traced
  // for) and whatever lives across passes.
  std::unique_ptr<Estimator> estimator;
  Epochs epochs;
  double last_build_ms = 0;
  size_t last_photon_map_bytes = 0;
  uint32_t photons_per_leaf = 0;  // 0: the estimator's own choice

  // Traces the photons of pass `pass` and has the estimator build its maps from them, adding the
  // cost to `timings`.
  void trace_pass_photons(uint32_t pass, StageTimings& timings, uint64_t& emitted,
                          uint64_t& caustic_count, uint64_t& global_count) {
    const RenderSettings& rs = scene.settings;
    auto t0 = std::chrono::steady_clock::now();
    PhotonTraceSettings trace{rs.photons_per_pass, rs.max_photon_bounces, rs.seed, pass};
    trace.differentials = estimator->needs_differentials();
    TracedPhotons traced = trace_photons(*backend, *resident, trace);
    backend->synchronize();
    timings.photon_trace_ms += elapsed_ms(t0);
    emitted += traced.emitted;
    caustic_count = traced.caustic.size();
    global_count = traced.global.size();

    auto t1 = std::chrono::steady_clock::now();
    estimator->prepare(*backend, *resident, traced, pass);
    backend->synchronize();
    timings.photon_map_build_ms += elapsed_ms(t1);
    last_photon_map_bytes = estimator->map_bytes();
  }

  // The light-change pipeline: photons and maps for the film's next pass, reported; none for
  // the path integrator, which traces no photons.
  void prepare_photons(RebuildReport& report) {
    estimator->drop_maps();  // frees the old maps before the new ones are allocated
    if (scene.settings.integrator != Integrator::kPhoton) return;
    trace_pass_photons(film->passes(), report.timings, report.photons_emitted,
                       report.caustic_photons, report.global_photons);
    report.rebuilt.push_back("photon_maps");
  }
};

Engine::Engine(std::unique_ptr<State> state) : state_(std::move(state)) {}
Engine::~Engine() = default;

absl::StatusOr<DeviceKind> parse_device_kind(std::string_view name) {
  if (name == "cpu") return DeviceKind::kCpu;
  if (name == "auto") return cuda_device_available() ? DeviceKind::kCuda : DeviceKind::kCpu;
  if (name == "cuda") {
    if (!kBuiltWithCuda) return no_cuda_backend();
    return DeviceKind::kCuda;  // whether a GPU is present is make_backend's question
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown device '", std::string(name), "' (expected auto, cpu or cuda)"));
}

const char* device_kind_name(DeviceKind kind) { return kind == DeviceKind::kCuda ? "cuda" : "cpu"; }

absl::StatusOr<std::shared_ptr<Backend>> make_backend(DeviceKind device,
                                                      size_t memory_budget_bytes) {
  switch (device) {
    case DeviceKind::kCpu:
      return std::shared_ptr<Backend>(make_cpu_backend(memory_budget_bytes));
    case DeviceKind::kCuda:
      break;
  }
#if defined(CAUSTICA_WITH_CUDA)
  if (!cuda_device_available()) {
    return absl::FailedPreconditionError("no CUDA device: the CUDA runtime finds no GPU or driver");
  }
  std::shared_ptr<Backend> backend;
  absl::Status status = guarded([&]() -> absl::Status {
    backend = make_cuda_backend(memory_budget_bytes);
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  return backend;
#else
  return no_cuda_backend();
#endif
}

absl::StatusOr<std::unique_ptr<Engine>> Engine::create(const EngineOptions& options) {
  auto state = std::make_unique<State>();
  if (options.backend) {
    state->backend = options.backend;
  } else {
    absl::StatusOr<std::shared_ptr<Backend>> backend =
        make_backend(options.device, options.memory_budget_bytes);
    if (!backend.ok()) return backend.status();
    state->backend = *std::move(backend);
  }
  state->photons_per_leaf = options.photons_per_leaf;
  return std::unique_ptr<Engine>(new Engine(std::move(state)));
}

absl::StatusOr<RebuildReport> Engine::load(const Scene& scene) {
  if (absl::Status s = validate_scene(scene); !s.ok()) return s;
  if (absl::Status s = media_support(scene, scene.settings); !s.ok()) return s;
  RebuildReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    State& st = *state_;
    st.estimator.reset();
    st.resident.reset();
    st.film.reset();
    auto start = std::chrono::steady_clock::now();
    st.resident.emplace(ResidentScene::upload(*st.backend, scene));
    st.backend->synchronize();
    st.last_build_ms = elapsed_ms(start);
    st.scene = scene;
    st.film.emplace(*st.backend, scene.camera.width, scene.camera.height);
    st.estimator =
        make_estimator(*st.backend, estimator_options(scene.settings, st.photons_per_leaf));
    ++st.epochs.geometry;
    ++st.epochs.lights;
    ++st.epochs.camera;
    ++st.epochs.settings;
    report.rebuilt = {"geometry", "lights", "film"};
    report.timings.structure_build_ms = st.last_build_ms;
    return absl::OkStatus();
  });
  if (!status.ok()) {
    // Nothing half-built stays behind: a failed load leaves an engine without a scene.
    state_->estimator.reset();
    state_->resident.reset();
    state_->film.reset();
    return status;
  }
  report.epochs = state_->epochs;
  return report;
}

absl::StatusOr<RebuildReport> Engine::set_lights(const std::vector<Light>& lights,
                                                 const std::vector<EmitterChange>& emitters) {
  State& st = *state_;
  if (!st.resident) return absl::FailedPreconditionError("no scene loaded");
  if (absl::Status s = validate_lights(lights, st.resident->view().area_light_count); !s.ok())
    return s;
  absl::StatusOr<std::vector<Material>> materials =
      apply_emitter_changes(st.scene.materials, emitters);
  if (!materials.ok()) return materials.status();
  RebuildReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    st.estimator->drop_maps();
    if (!emitters.empty()) {
      st.resident->set_emission(*materials);
      st.scene.materials = *std::move(materials);
    }
    st.resident->set_lights(lights);
    st.scene.lights = lights;
    st.film->clear();
    ++st.epochs.lights;
    report.rebuilt = {"lights", "film"};
    st.prepare_photons(report);
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  report.epochs = st.epochs;
  return report;
}

absl::StatusOr<RebuildReport> Engine::set_camera(const Camera& camera) {
  State& st = *state_;
  if (!st.resident) return absl::FailedPreconditionError("no scene loaded");
  if (absl::Status s = validate_camera(camera); !s.ok()) return s;
  RebuildReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    if (camera.width != st.scene.camera.width || camera.height != st.scene.camera.height) {
      st.film.reset();
      st.film.emplace(*st.backend, camera.width, camera.height);
    } else {
      st.film->clear();
    }
    st.scene.camera = camera;
    ++st.epochs.camera;
    report.rebuilt = {"film"};
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  report.epochs = st.epochs;
  return report;
}

absl::StatusOr<RebuildReport> Engine::set_settings(const RenderSettings& settings,
                                                   const ImageSize& size) {
  State& st = *state_;
  if (!st.resident) return absl::FailedPreconditionError("no scene loaded");
  // Everything is checked before anything changes, so a refused change changes nothing.
  Camera camera = st.scene.camera;
  for (auto [field, value, side] : {std::tuple{"width", size.width, &camera.width},
                                    std::tuple{"height", size.height, &camera.height}}) {
    if (value > uint32_t(kMaxImageSide)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: %d is outside [1, %d] (0 keeps the current size)", field, value, kMaxImageSide));
    }
    if (value > 0) *side = int(value);
  }
  if (absl::Status s = validate_settings(settings); !s.ok()) return s;
  if (absl::Status s = validate_camera(camera); !s.ok()) return s;
  if (absl::Status s = media_support(st.scene, settings); !s.ok()) return s;
  const RenderSettings& old = st.scene.settings;
  const bool estimator_change = !same_estimator(settings, old);
  // A new estimator has no maps: the photons are traced again for it.
  const bool photons_change = settings.photons_per_pass != old.photons_per_pass ||
                              settings.max_photon_bounces != old.max_photon_bounces ||
                              settings.seed != old.seed || estimator_change;
  const bool structure_change = settings.structure != old.structure;
  const bool resize =
      camera.width != st.scene.camera.width || camera.height != st.scene.camera.height;
  RebuildReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    // The new film first: when it does not fit, nothing has changed yet.
    std::optional<Film> film;
    if (resize) film.emplace(*st.backend, camera.width, camera.height);
    if (structure_change) {
      // The photons traced ahead went through the old structure: they are traced again through
      // the new one, as after any geometry change.
      st.estimator->drop_maps();
      auto start = std::chrono::steady_clock::now();
      st.resident->rebuild_structure(settings.structure);
      st.backend->synchronize();
      st.last_build_ms = elapsed_ms(start);
      report.timings.structure_build_ms = st.last_build_ms;
      ++st.epochs.geometry;
    }
    if (estimator_change)
      st.estimator = make_estimator(*st.backend, estimator_options(settings, st.photons_per_leaf));
    st.scene.settings = settings;
    if (resize) {
      st.film = std::move(film);
      st.scene.camera = camera;
      ++st.epochs.camera;
    } else {
      st.film->clear();
    }
    ++st.epochs.settings;
    report.rebuilt = structure_change ? std::vector<std::string>{"geometry", "film"}
                                      : std::vector<std::string>{"film"};
    if (photons_change || structure_change) st.prepare_photons(report);
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  report.epochs = st.epochs;
  return report;
}

ShadingSettings Engine::shading(uint32_t pass) const {
  const State& st = *state_;
  const RenderSettings& rs = st.scene.settings;
  // The gather radius cap: the setting, or 5% of the scene's diagonal when it is 0.
  float max_radius = rs.max_radius;
  if (max_radius <= 0)
    max_radius = st.resident ? 0.05f * length(st.resident->bounds().extent()) : 0.0f;
  return {rs.k_nearest, max_radius, rs.kernel, rs.max_depth, rs.area_light_samples, rs.seed, pass};
}

absl::StatusOr<PassReport> Engine::render(uint32_t passes, const Progress& progress) {
  State& st = *state_;
  if (!st.resident) return absl::FailedPreconditionError("no scene loaded");
  PassReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    const PinholeCamera camera = PinholeCamera::from(st.scene.camera);
    Backend& backend = *st.backend;
    for (uint32_t i = 0; i < passes; ++i) {
      const uint32_t pass = st.film->passes();
      const bool path = st.scene.settings.integrator == Integrator::kPath;
      // Photons traced ahead by a light change serve the pass they were traced for; the path
      // integrator takes none.
      if (path) {
        st.last_photon_map_bytes = 0;
        st.estimator->drop_maps();
      } else if (!st.estimator->prepared_for(pass)) {
        st.trace_pass_photons(pass, report.timings, report.photons_emitted, report.caustic_photons,
                              report.global_photons);
      }

      auto t0 = std::chrono::steady_clock::now();
      if (path) {
        render_path_pass(backend, *st.resident, camera, {st.scene.settings.seed, pass}, *st.film);
      } else {
        st.estimator->render(backend, *st.resident, camera, shading(pass), *st.film);
      }
      backend.synchronize();
      report.timings.render_ms += elapsed_ms(t0);
      ++report.passes_rendered;
      if (progress) progress(i + 1, passes);
    }
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  report.total_passes = st.film->passes();
  return report;
}

std::span<const float> Engine::image_linear() { return state_->film->resolve_linear(); }
std::span<const Rgba8> Engine::image_srgb8(float exposure_stops) {
  return state_->film->resolve_srgb8(exposure_stops);
}
const Scene& Engine::scene() const { return state_->scene; }
const Epochs& Engine::epochs() const { return state_->epochs; }
void Engine::restore_epochs(const Epochs& epochs) { state_->epochs = epochs; }
uint32_t Engine::film_passes() const { return state_->film ? state_->film->passes() : 0; }
DeviceInfo Engine::device_info() const { return state_->backend->info(); }
Backend& Engine::backend() { return *state_->backend; }

SceneStats Engine::scene_stats() const {
  const State& st = *state_;
  SceneStats s;
  if (!st.resident) return s;
  s.triangles = st.resident->triangle_count();
  const StructureStats& structure = st.resident->structure().stats();
  s.structure = structure.kind;
  s.structure_nodes = structure.nodes;
  s.structure_bytes = structure.bytes;
  s.structure_sah_cost = structure.sah_cost;
  s.photon_map_bytes = st.last_photon_map_bytes;
  s.device_bytes = st.resident->bytes() + (st.film ? st.film->bytes() : 0) +
                   (st.estimator ? st.estimator->map_bytes() + st.estimator->state_bytes() : 0);
  s.lights = st.resident->view().light_count;
  s.last_structure_build_ms = st.last_build_ms;
  return s;
}

}  // namespace caustica
