#include "renderer/engine.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <map>
#include <optional>
#include <stdexcept>
#include <thread>
#include <tuple>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "renderer/estimator/estimator.h"
#include "renderer/photon/photon_map.h"
#include "renderer/photon/photon_shares.h"
#include "renderer/photon/photon_tracer.h"
#include "renderer/render/camera.h"
#include "renderer/render/path_tracer.h"
#include "renderer/render/whitted.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/emitters.h"
#include "renderer/scene/scene_json.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/texture_decode.h"
#include "renderer/scene/transform.h"
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
    // path integrator, a batch-only structure).
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
  if (answers_batches_only(rs.structure)) {
    return absl::UnimplementedError(
        absl::StrCat("media: the ", structure_kind_name(rs.structure),
                     " structure answers ray batches only, and the ray queues do not trace through "
                     "participating media yet; choose another structure"));
  }
  if (rs.integrator == Integrator::kPath) return absl::OkStatus();
  if (rs.estimator != EstimatorKind::kKnn && rs.estimator != EstimatorKind::kVkde) {
    return absl::UnimplementedError(absl::StrCat(
        "media: the ", kind_name(rs.estimator),
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
  return {.kind = rs.estimator,
          .k_nearest = rs.k_nearest,
          .photons_per_leaf = photons_per_leaf,
          .sppm_alpha = rs.sppm_alpha,
          .sppm_radius = rs.sppm_radius,
          .vkde_spread = rs.vkde_spread,
          .final_gather = rs.final_gather,
          .final_gather_rays = rs.final_gather_rays,
          .final_gather_seeds = rs.final_gather_seeds};
}

// Whether a settings change keeps the estimator: the options it is made from, all of them.
bool same_estimator(const RenderSettings& a, const RenderSettings& b) {
  return estimator_options(a, 0) == estimator_options(b, 0);
}

// Whether `b`'s structure is the one `a` builds, so that a change of an option no builder of the
// kind reads rebuilds nothing.
bool same_structure(const RenderSettings& a, const RenderSettings& b) {
  return a.structure == b.structure &&
         options_read_by(a.structure, a.build) == options_read_by(b.structure, b.build);
}

// What a geometry change did to the structure, as its report names it: "structure_refit" for a
// refit (RefitPolicy), "structure" for a new build, and nothing for dacrt, which keeps none.
std::vector<std::string> geometry_change_rebuilt(const StructureStats& structure) {
  if (structure.kind == StructureKind::kDacrt) return {"geometry", "lights", "film"};
  return {"geometry", structure.refits > 0 ? "structure_refit" : "structure", "lights", "film"};
}

// Rows per band when an image is dealt to several devices (RowBands): a multiple of the 8 x 4
// pixel blocks the camera rays go in, and small enough that a bright region spans every device.
constexpr int kBandRows = 32;

// One device's part of the engine: its copy of the scene and its structure, its estimator (the
// maps and what lives across passes) and the film of its bands of rows.
struct DeviceSlice {
  std::shared_ptr<Backend> backend;
  RowBands bands;
  std::optional<ResidentScene> resident;
  std::optional<Film> film;  // none where the image has no rows for this device
  std::unique_ptr<Estimator> estimator;

  void clear() {
    estimator.reset();
    resident.reset();
    film.reset();
  }
};

struct Engine::State {
  std::vector<DeviceSlice> slices;  // the first one answers for the engine where one must
  Scene scene;
  // The meshes set_geometry moved or reshaped, by index into scene.meshes: their vertices as
  // uploaded or last replaced, and the map that places them in `scene` now.
  struct Placement {
    Mesh rest;
    Affine transform;
    bool positions_replaced = false, normals_replaced = false;
  };
  std::map<size_t, Placement> placements;
  Epochs epochs;
  double last_build_ms = 0;
  size_t last_photon_map_bytes = 0;
  uint32_t photons_per_leaf = 0;  // 0: the estimator's own choice
  // The whole image from several devices' films, kept between frames.
  std::vector<float> image_linear;
  std::vector<Rgba8> image_srgb8;

  DeviceSlice& first() { return slices.front(); }
  const DeviceSlice& first() const { return slices.front(); }
  bool loaded() const { return first().resident.has_value(); }

  // Runs `work(slice, index)` for every device at once, a thread each beyond the caller's, with
  // that device current; rethrows the first device's failure once all are done.
  template <typename Work>
  void on_every_device(Work&& work) {
    if (slices.size() == 1) {
      slices[0].backend->make_current();
      work(slices[0], size_t(0));
      return;
    }
    std::vector<std::exception_ptr> failures(slices.size());
    auto run = [&](size_t i) {
      try {
        slices[i].backend->make_current();
        work(slices[i], i);
      } catch (...) {
        failures[i] = std::current_exception();
      }
    };
    std::vector<std::thread> threads;
    threads.reserve(slices.size() - 1);
    for (size_t i = 1; i < slices.size(); ++i) threads.emplace_back(run, i);
    run(0);
    for (std::thread& t : threads) t.join();
    for (const std::exception_ptr& failure : failures) {
      if (failure) std::rethrow_exception(failure);
    }
  }

  // Runs `make(slice)` for every device at once and returns what each made.
  template <typename T, typename Make>
  std::vector<T> make_on_every_device(Make&& make) {
    std::vector<T> made(slices.size());
    on_every_device([&](DeviceSlice& d, size_t i) { made[i] = make(d); });
    return made;
  }

  // A change builds what it replaces beside what is in use, on every device, and swaps it in only
  // once all of it is there: one that does not fit leaves everything as it was, and a swap back
  // undoes it without allocating. The films, the estimators, the structures and the lighting:
  std::vector<std::optional<Film>> new_films(int width, int height) {
    return make_on_every_device<std::optional<Film>>([&](DeviceSlice& d) {
      std::optional<Film> film;
      const int rows = d.bands.film_rows(height);
      if (rows > 0) film.emplace(*d.backend, width, rows);
      return film;
    });
  }
  void swap_films(std::vector<std::optional<Film>>& films) {
    for (size_t i = 0; i < slices.size(); ++i) std::swap(slices[i].film, films[i]);
  }
  std::vector<std::unique_ptr<Estimator>> new_estimators(const RenderSettings& settings) {
    return make_on_every_device<std::unique_ptr<Estimator>>([&](DeviceSlice& d) {
      return make_estimator(*d.backend, estimator_options(settings, photons_per_leaf));
    });
  }
  void swap_estimators(std::vector<std::unique_ptr<Estimator>>& estimators) {
    for (size_t i = 0; i < slices.size(); ++i) slices[i].estimator.swap(estimators[i]);
  }
  std::vector<TriangleStructure> new_structures(StructureKind kind, const BuildOptions& options) {
    return make_on_every_device<TriangleStructure>([&](DeviceSlice& d) {
      TriangleStructure structure = d.resident->new_structure(kind, options);
      d.backend->synchronize();
      return structure;
    });
  }
  void swap_structures(std::vector<TriangleStructure>& structures) {
    for (size_t i = 0; i < slices.size(); ++i) slices[i].resident->swap_structure(structures[i]);
  }
  // The whole scene uploaded again beside what is in use: geometry, structure and lighting.
  // Moved and reshaped meshes: only the triangles' corners, area lights and structure, on every
  // device; textures, materials and media stay.
  std::vector<ResidentScene::Geometry> new_geometries(const Scene& next) {
    return make_on_every_device<ResidentScene::Geometry>([&](DeviceSlice& d) {
      ResidentScene::Geometry geometry = d.resident->new_geometry(next);
      d.backend->synchronize();
      return geometry;
    });
  }
  void swap_geometries(std::vector<ResidentScene::Geometry>& geometries) {
    for (size_t i = 0; i < slices.size(); ++i) slices[i].resident->swap_geometry(geometries[i]);
  }
  std::vector<ResidentScene::Lighting> new_lighting(const std::vector<Light>& lights,
                                                    const std::vector<Material>& materials,
                                                    const Environment& environment) {
    return make_on_every_device<ResidentScene::Lighting>(
        [&](DeviceSlice& d) { return d.resident->new_lighting(lights, materials, environment); });
  }
  void swap_lighting(std::vector<ResidentScene::Lighting>& lighting) {
    for (size_t i = 0; i < slices.size(); ++i) slices[i].resident->swap_lighting(lighting[i]);
  }

  void drop_maps() {
    on_every_device([](DeviceSlice& d, size_t) { d.estimator->drop_maps(); });
  }

  // Traces the photons of pass `pass` and has the estimators build their maps from them, adding
  // the cost to `timings`. On several devices each traces its share of the paths, and every
  // device's maps are built from all the shares merged in the whole pass's order.
  void trace_pass_photons(const RenderSettings& rs, uint32_t pass, StageTimings& timings,
                          uint64_t& emitted, uint64_t& caustic_count, uint64_t& global_count) {
    const size_t devices = slices.size();
    PhotonTraceSettings trace = photon_trace_settings(rs, rs.photons_per_pass, pass);
    trace.differentials = first().estimator->needs_differentials();
    auto t0 = std::chrono::steady_clock::now();
    std::vector<TracedPhotons> shares(devices);
    on_every_device([&](DeviceSlice& d, size_t i) {
      PhotonTraceSettings share = trace;
      share.total_paths = trace.photon_count;
      share.first_path = uint32_t(uint64_t(trace.photon_count) * i / devices);
      share.photon_count =
          uint32_t(uint64_t(trace.photon_count) * (i + 1) / devices) - share.first_path;
      shares[i] = trace_photons(*d.backend, *d.resident, share);
      d.backend->synchronize();
    });
    timings.photon_trace_ms += elapsed_ms(t0);

    auto t1 = std::chrono::steady_clock::now();
    on_every_device([&](DeviceSlice& d, size_t) {
      if (devices == 1) {
        d.estimator->prepare(*d.backend, *d.resident, shares[0], pass);
      } else {
        const TracedPhotons merged = merge_traced_photons(*d.backend, shares);
        d.estimator->prepare(*d.backend, *d.resident, merged, pass);
      }
      d.backend->synchronize();
    });
    timings.photon_map_build_ms += elapsed_ms(t1);
    caustic_count = 0;
    global_count = 0;
    for (const TracedPhotons& share : shares) {
      emitted += share.emitted;
      caustic_count += share.caustic.size();
      global_count += share.global.size();
    }
    last_photon_map_bytes = first().estimator->map_bytes();
  }

  // The light-change pipeline: photons and maps with `rs` for the first pass of the film a
  // change restarts, reported; none for the path integrator, which traces no photons. The maps of
  // a failed trace are dropped, so that no pass takes them for its own.
  void prepare_photons(const RenderSettings& rs, RebuildReport& report) {
    drop_maps();  // frees the old maps before the new ones are allocated
    if (rs.integrator != Integrator::kPhoton) return;
    try {
      trace_pass_photons(rs, 0, report.timings, report.photons_emitted, report.caustic_photons,
                         report.global_photons);
    } catch (...) {
      drop_maps();
      throw;
    }
    report.rebuilt.push_back("photon_maps");
  }

  void clear_films() {
    on_every_device([](DeviceSlice& d, size_t) {
      if (d.film) d.film->clear();
    });
  }

  // The devices' films resolved and their rows put in image order; one device's film is the
  // image itself.
  template <typename Pixel, typename Resolve>
  std::span<const Pixel> whole_image(std::vector<Pixel>& image, int channels, Resolve&& resolve) {
    if (slices.size() == 1) return resolve(*first().film);
    const int width = scene.camera.width;
    image.resize(size_t(width) * scene.camera.height * channels);
    on_every_device([&](DeviceSlice& d, size_t) {
      if (!d.film) return;
      const std::span<const Pixel> rows = resolve(*d.film);
      const size_t row_size = size_t(width) * channels;
      for (int y = 0; y < d.film->height(); ++y) {
        std::copy_n(rows.data() + size_t(y) * row_size, row_size,
                    image.data() + size_t(d.bands.image_row(y)) * row_size);
      }
    });
    return image;
  }
};

Engine::Engine(std::unique_ptr<State> state) : state_(std::move(state)) {}

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

int device_count(DeviceKind device) {
  if (device == DeviceKind::kCpu) return 1;
#if defined(CAUSTICA_WITH_CUDA)
  return cuda_device_count();
#else
  return 0;
#endif
}

absl::StatusOr<std::shared_ptr<Backend>> make_backend(DeviceKind device, size_t memory_budget_bytes,
                                                      int ordinal) {
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
    const int count = cuda_device_count();
    if (ordinal >= count) {
      return absl::InvalidArgumentError(
          absl::StrCat("no CUDA device ", ordinal, ": this machine has ", count,
                       count == 1 ? " GPU" : " GPUs", " (0 to ", count - 1, ")"));
    }
    backend = make_cuda_backend(memory_budget_bytes, ordinal);
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
  std::vector<std::shared_ptr<Backend>> backends = options.backends;
  if (backends.empty() && options.backend) backends.push_back(options.backend);
  if (backends.empty()) {
    absl::StatusOr<std::shared_ptr<Backend>> backend =
        make_backend(options.device, options.memory_budget_bytes);
    if (!backend.ok()) return backend.status();
    backends.push_back(*std::move(backend));
  }
  for (size_t i = 0; i < backends.size(); ++i) {
    if (!backends[i]) return absl::InvalidArgumentError(absl::StrCat("backend ", i, " is null"));
    DeviceSlice slice;
    slice.backend = backends[i];
    slice.bands = {kBandRows, int(backends.size()), int(i)};
    state->slices.push_back(std::move(slice));
  }
  state->photons_per_leaf = options.photons_per_leaf;
  return std::unique_ptr<Engine>(new Engine(std::move(state)));
}

Engine::~Engine() {
  // Each device's memory goes back on its own device.
  if (state_) state_->on_every_device([](DeviceSlice& d, size_t) { d.clear(); });
}

absl::StatusOr<RebuildReport> Engine::load(const Scene& given) {
  // Texture images not decoded yet (a scene loaded from files rather than uploaded) are decoded
  // on a copy, sharing everything else.
  std::optional<Scene> decoded;
  const bool undecoded = std::any_of(given.textures.begin(), given.textures.end(),
                                     [](const TextureImage& t) { return t.decoded == nullptr; });
  if (undecoded) {
    decoded = given;
    if (absl::Status s = decode_textures(*decoded); !s.ok()) return s;
  }
  const Scene& scene = decoded ? *decoded : given;
  if (absl::Status s = validate_scene(scene); !s.ok()) return s;
  if (absl::Status s = media_support(scene, scene.settings); !s.ok()) return s;
  RebuildReport report;
  State& st = *state_;
  absl::Status status = guarded([&]() -> absl::Status {
    st.on_every_device([](DeviceSlice& d, size_t) { d.clear(); });
    auto start = std::chrono::steady_clock::now();
    st.on_every_device([&](DeviceSlice& d, size_t) {
      d.resident.emplace(ResidentScene::upload(*d.backend, scene));
      d.backend->synchronize();
    });
    st.last_build_ms = elapsed_ms(start);
    st.scene = scene;
    st.placements.clear();
    std::vector<std::optional<Film>> films = st.new_films(scene.camera.width, scene.camera.height);
    st.swap_films(films);
    std::vector<std::unique_ptr<Estimator>> estimators = st.new_estimators(scene.settings);
    st.swap_estimators(estimators);
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
    st.on_every_device([](DeviceSlice& d, size_t) { d.clear(); });
    return status;
  }
  report.epochs = st.epochs;
  return report;
}

namespace {

// The meshes `name` names in `scene`, or the error naming `field`: the one mesh of that name, or
// else every mesh of the one scene-file shape the scene calls so (a model file's parts move as
// one).
absl::StatusOr<std::vector<size_t>> meshes_named(const Scene& scene, const std::string& name,
                                                 const std::string& field) {
  std::vector<size_t> exact, shape;
  absl::string_view shape_path;
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const std::string& mesh = scene.meshes[i].name;
    if (mesh == name) exact.push_back(i);
    const ShapeLabel label = parse_shape_label(mesh);
    if (label.name != name) continue;
    if (!shape.empty() && label.path != shape_path) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": '", name, "' names two shapes (",
                                                     shape_path, " and ", label.path,
                                                     "): give the mesh's whole name"));
    }
    shape_path = label.path;
    shape.push_back(i);
  }
  if (exact.size() > 1) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": '", name,
                                                   "' names more than one mesh (meshes[", exact[0],
                                                   "] and meshes[", exact[1], "])"));
  }
  if (!exact.empty()) return exact;
  if (shape.empty()) {
    return absl::NotFoundError(absl::StrCat(field, ": the scene has no mesh named '", name, "' (",
                                            scene.meshes.size(), " meshes)"));
  }
  return shape;
}

// `vectors` as the new value of a mesh's `count` vertices' attribute `field`, or why not.
absl::Status check_vertices(const std::vector<Vec3f>& vectors, size_t count,
                            const std::string& field) {
  if (vectors.size() != count) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", vectors.size(), " vertices, but the mesh has ", count));
  }
  for (size_t i = 0; i < vectors.size(); ++i) {
    const Vec3f v = vectors[i];
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s[%d]: (%g, %g, %g) is not finite", field, i, v.x, v.y, v.z));
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<RebuildReport> Engine::set_lights(const std::vector<Light>& lights,
                                                 const std::vector<EmitterChange>& emitters,
                                                 const EnvironmentChange& environment) {
  return apply(SceneChange{lights, emitters, environment, {}});
}

absl::StatusOr<RebuildReport> Engine::set_geometry(std::span<const MeshChange> changes) {
  return apply(SceneChange{std::nullopt, {}, {}, {changes.begin(), changes.end()}});
}

namespace {

// A mesh change checked against `scene`: the meshes it changes, or the error naming the field.
absl::StatusOr<std::vector<size_t>> check_mesh_change(const Scene& scene, const MeshChange& change,
                                                      const std::string& field) {
  absl::StatusOr<std::vector<size_t>> meshes = meshes_named(scene, change.mesh, field + ".mesh");
  if (!meshes.ok()) return meshes.status();
  const size_t count = scene.meshes[meshes->front()].positions.size();
  for (const auto& [vertices, name] :
       {std::pair{&change.positions, ".positions"}, std::pair{&change.normals, ".normals"}}) {
    if (!*vertices) continue;
    if (meshes->size() > 1) {
      return absl::InvalidArgumentError(absl::StrCat(
          field, name, ": '", change.mesh, "' is a shape of ", meshes->size(),
          " meshes; new vertices go to one of them, named whole, as SceneInfo lists it"));
    }
    if (absl::Status s = check_vertices(**vertices, count, field + name); !s.ok()) return s;
  }
  if (change.transform) {
    bool finite = true;
    for (const auto& row : change.transform->m)
      for (const double x : row) finite &= std::isfinite(x);
    const double det = change.transform->determinant();
    if (!finite || !(std::fabs(det) > 0) || !std::isfinite(det)) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".transform: is not an invertible map of finite numbers"));
    }
  }
  return meshes;
}

// The lights, materials and environment of `scene` after `change`, or why not.
struct LightingState {
  std::vector<Light> lights;
  std::vector<Material> materials;
  Environment environment;
};
absl::StatusOr<LightingState> changed_lighting(const Scene& scene, uint32_t area_lights,
                                               const SceneChange& change) {
  LightingState out{scene.lights, {}, scene.environment};
  if (change.lights) {
    if (absl::Status s = validate_lights(*change.lights, area_lights, scene.environment.present);
        !s.ok())
      return s;
    out.lights = *change.lights;
  }
  const EnvironmentChange& environment = change.environment;
  if (absl::Status s = validate_environment_change(environment); !s.ok()) return s;
  if (environment.intensity || environment.rotation_deg) {
    if (!out.environment.present) {
      return absl::FailedPreconditionError(
          "environment: the scene has no environment to change (add one to the scene)");
    }
    out.environment.intensity = environment.intensity.value_or(out.environment.intensity);
    out.environment.rotation_deg = environment.rotation_deg.value_or(out.environment.rotation_deg);
  }
  absl::StatusOr<std::vector<Material>> materials =
      apply_emitter_changes(scene.materials, change.emitters);
  if (!materials.ok()) return materials.status();
  out.materials = *std::move(materials);
  return out;
}

}  // namespace

absl::Status Engine::check(const SceneChange& change) const {
  const State& st = *state_;
  if (!st.loaded()) return absl::FailedPreconditionError("no scene loaded");
  absl::StatusOr<LightingState> lighting =
      changed_lighting(st.scene, st.first().resident->view().area_light_count, change);
  if (!lighting.ok()) return lighting.status();
  for (size_t c = 0; c < change.meshes.size(); ++c) {
    absl::StatusOr<std::vector<size_t>> meshes =
        check_mesh_change(st.scene, change.meshes[c], absl::StrCat("meshes[", c, "]"));
    if (!meshes.ok()) return meshes.status();
  }
  return absl::OkStatus();
}

absl::StatusOr<RebuildReport> Engine::apply(const SceneChange& change) {
  State& st = *state_;
  if (!st.loaded()) return absl::FailedPreconditionError("no scene loaded");
  absl::StatusOr<LightingState> lighting =
      changed_lighting(st.scene, st.first().resident->view().area_light_count, change);
  if (!lighting.ok()) return lighting.status();
  // A geometry change checks the scene as it will be, whole, before anything changes; a light
  // change leaves the meshes alone and copies none of them.
  const bool geometry = !change.meshes.empty();
  std::optional<Scene> next;
  std::map<size_t, State::Placement> placements;
  if (geometry) {
    next = st.scene;
    placements = st.placements;
  }
  for (size_t c = 0; c < change.meshes.size(); ++c) {
    const MeshChange& mesh_change = change.meshes[c];
    absl::StatusOr<std::vector<size_t>> meshes =
        check_mesh_change(st.scene, mesh_change, absl::StrCat("meshes[", c, "]"));
    if (!meshes.ok()) return meshes.status();
    for (const size_t index : *meshes) {
      // A mesh placed for the first time stands where it was uploaded.
      State::Placement& placed =
          placements.try_emplace(index, State::Placement{st.scene.meshes[index], Affine()})
              .first->second;
      Mesh& rest = placed.rest;
      if (mesh_change.positions) {
        rest.positions = *mesh_change.positions;
        rest.tangents.clear();
        if (!mesh_change.normals) rest.normals.clear();
        placed.positions_replaced = true;
      }
      if (mesh_change.normals) {
        rest.normals = *mesh_change.normals;
        placed.normals_replaced = true;
      }
      if (mesh_change.transform) placed.transform = *mesh_change.transform;
      Mesh moved = rest;
      transform_mesh(placed.transform, &moved);
      next->meshes[index] = std::move(moved);
    }
  }
  if (geometry) {
    next->lights = lighting->lights;
    next->materials = lighting->materials;
    next->environment = lighting->environment;
    if (absl::Status s = validate_scene(*next); !s.ok()) return s;
  }
  RebuildReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    st.drop_maps();  // frees the old maps before the new scene state is allocated
    // The photons are traced in the new state before the films restart; when that fails, the
    // old state goes back.
    std::vector<ResidentScene::Geometry> geometries;
    std::vector<ResidentScene::Lighting> resident_lighting;
    if (geometry) {
      const auto start = std::chrono::steady_clock::now();
      geometries = st.new_geometries(*next);
      report.timings.structure_build_ms = elapsed_ms(start);
      report.rebuilt = geometry_change_rebuilt(geometries.front().structure.stats());
      // The lighting follows the new area lights and bounds, so it is made after the swap.
      st.swap_geometries(geometries);
    } else {
      report.rebuilt = {"lights", "film"};
    }
    try {
      resident_lighting =
          st.new_lighting(lighting->lights, lighting->materials, lighting->environment);
    } catch (...) {
      if (geometry) st.swap_geometries(geometries);
      throw;
    }
    const auto swap = [&] {
      st.swap_lighting(resident_lighting);
      if (geometry) st.swap_geometries(geometries);
    };
    st.swap_lighting(resident_lighting);
    try {
      st.prepare_photons(st.scene.settings, report);
    } catch (...) {
      swap();
      throw;
    }
    st.clear_films();
    if (geometry) {
      st.scene = *std::move(next);
      st.placements = std::move(placements);
      st.last_build_ms = report.timings.structure_build_ms;
      ++st.epochs.geometry;
    } else {
      st.scene.lights = std::move(lighting->lights);
      st.scene.materials = std::move(lighting->materials);
      st.scene.environment = lighting->environment;
    }
    ++st.epochs.lights;
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  report.epochs = st.epochs;
  return report;
}

std::vector<MeshChange> Engine::placements() const {
  std::vector<MeshChange> out;
  for (const auto& [index, placed] : state_->placements) {
    MeshChange& change = out.emplace_back();
    change.mesh = state_->scene.meshes[index].name;
    change.transform = placed.transform;
    if (placed.positions_replaced) {
      change.positions = placed.rest.positions;
      if (!placed.rest.normals.empty()) change.normals = placed.rest.normals;
    } else if (placed.normals_replaced) {
      change.normals = placed.rest.normals;
    }
  }
  return out;
}

absl::StatusOr<RebuildReport> Engine::set_camera(const Camera& camera) {
  State& st = *state_;
  if (!st.loaded()) return absl::FailedPreconditionError("no scene loaded");
  if (absl::Status s = validate_camera(camera); !s.ok()) return s;
  RebuildReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    if (camera.width != st.scene.camera.width || camera.height != st.scene.camera.height) {
      std::vector<std::optional<Film>> films = st.new_films(camera.width, camera.height);
      st.swap_films(films);
    } else {
      st.clear_films();
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
  if (!st.loaded()) return absl::FailedPreconditionError("no scene loaded");
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
  const bool photons_change = photon_trace_settings(settings, settings.photons_per_pass, 0) !=
                                  photon_trace_settings(old, old.photons_per_pass, 0) ||
                              estimator_change;
  const bool structure_change = !same_structure(settings, old);
  const bool resize =
      camera.width != st.scene.camera.width || camera.height != st.scene.camera.height;
  RebuildReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    // Everything new first: when one part does not fit, nothing has changed yet.
    std::vector<std::optional<Film>> films;
    if (resize) films = st.new_films(camera.width, camera.height);
    std::vector<std::unique_ptr<Estimator>> estimators;
    if (estimator_change) estimators = st.new_estimators(settings);
    std::vector<TriangleStructure> structures;
    if (structure_change) {
      // The photons traced ahead went through the old structure: they are traced again through
      // the new one, as after any geometry change.
      st.drop_maps();
      auto start = std::chrono::steady_clock::now();
      structures = st.new_structures(settings.structure, settings.build);
      report.timings.structure_build_ms = elapsed_ms(start);
    }
    report.rebuilt = structure_change ? std::vector<std::string>{"geometry", "film"}
                                      : std::vector<std::string>{"film"};
    // The photons are traced through the new structure for the new estimator; when that fails,
    // the same swap puts the old ones back.
    auto swap_new = [&] {
      if (structure_change) st.swap_structures(structures);
      if (estimator_change) st.swap_estimators(estimators);
    };
    swap_new();
    if (photons_change || structure_change) {
      try {
        st.prepare_photons(settings, report);
      } catch (...) {
        swap_new();
        throw;
      }
    }
    st.scene.settings = settings;
    if (structure_change) {
      st.last_build_ms = report.timings.structure_build_ms;
      ++st.epochs.geometry;
    }
    if (resize) {
      st.swap_films(films);
      st.scene.camera = camera;
      ++st.epochs.camera;
    } else {
      st.clear_films();
    }
    ++st.epochs.settings;
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
    max_radius = st.loaded() ? 0.05f * length(st.first().resident->bounds().extent()) : 0.0f;
  return {rs.k_nearest, max_radius, rs.kernel, rs.max_depth, rs.area_light_samples, rs.seed, pass};
}

absl::StatusOr<PassReport> Engine::render(uint32_t passes, const Progress& progress) {
  State& st = *state_;
  if (!st.loaded()) return absl::FailedPreconditionError("no scene loaded");
  PassReport report;
  absl::Status status = guarded([&]() -> absl::Status {
    const PinholeCamera camera = PinholeCamera::from(st.scene.camera);
    for (uint32_t i = 0; i < passes; ++i) {
      const uint32_t pass = st.first().film->passes();
      const bool path = st.scene.settings.integrator == Integrator::kPath;
      // Photons traced ahead by a light change serve the pass they were traced for; the path
      // integrator takes none.
      if (path) {
        st.last_photon_map_bytes = 0;
        st.drop_maps();
      } else if (!st.first().estimator->prepared_for(pass)) {
        st.trace_pass_photons(st.scene.settings, pass, report.timings, report.photons_emitted,
                              report.caustic_photons, report.global_photons);
      }

      auto t0 = std::chrono::steady_clock::now();
      const ShadingSettings shading_settings = shading(pass);
      st.on_every_device([&](DeviceSlice& d, size_t) {
        if (!d.film) {
          d.estimator->drop_maps();  // no rows here: the maps serve no pixel
          return;
        }
        const PinholeCamera rows = camera.with_bands(d.bands);
        if (path) {
          render_path_pass(*d.backend, *d.resident, rows, {st.scene.settings.seed, pass}, *d.film);
        } else {
          d.estimator->render(*d.backend, *d.resident, rows, shading_settings, *d.film);
        }
        d.backend->synchronize();
      });
      report.timings.render_ms += elapsed_ms(t0);
      ++report.passes_rendered;
      if (progress) progress(i + 1, passes);
    }
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  report.total_passes = st.first().film->passes();
  return report;
}

std::span<const float> Engine::image_linear() {
  return state_->whole_image(state_->image_linear, 4,
                             [](Film& film) { return film.resolve_linear(); });
}
std::span<const Rgba8> Engine::image_srgb8(float exposure_stops) {
  return state_->whole_image(state_->image_srgb8, 1, [exposure_stops](Film& film) {
    return film.resolve_srgb8(exposure_stops);
  });
}
const Scene& Engine::scene() const { return state_->scene; }
const Epochs& Engine::epochs() const { return state_->epochs; }
void Engine::restore_epochs(const Epochs& epochs) { state_->epochs = epochs; }
uint32_t Engine::film_passes() const {
  return state_->first().film ? state_->first().film->passes() : 0;
}
DeviceInfo Engine::device_info() const { return state_->first().backend->info(); }
std::vector<DeviceInfo> Engine::devices() const {
  std::vector<DeviceInfo> out;
  for (const DeviceSlice& d : state_->slices) out.push_back(d.backend->info());
  return out;
}
Backend& Engine::backend() { return *state_->first().backend; }
std::vector<Backend*> Engine::backends() {
  std::vector<Backend*> out;
  for (DeviceSlice& d : state_->slices) out.push_back(d.backend.get());
  return out;
}

size_t Engine::geometry_change_bytes() const {
  size_t bytes = 0;
  if (state_->loaded())
    for (const DeviceSlice& d : state_->slices) bytes += d.resident->geometry_change_bytes();
  return bytes;
}

SceneStats Engine::scene_stats() const {
  const State& st = *state_;
  SceneStats s;
  if (!st.loaded()) return s;
  const ResidentScene& resident = *st.first().resident;
  s.triangles = resident.triangle_count();
  const StructureStats& structure = resident.structure().stats();
  s.structure = structure.kind;
  s.structure_nodes = structure.nodes;
  s.structure_bytes = structure.bytes;
  s.structure_sah_cost = structure.sah_cost;
  s.structure_refits = structure.refits;
  s.structure_built_sah_cost = structure.built_sah_cost;
  s.photon_map_bytes = st.last_photon_map_bytes;
  for (const DeviceSlice& d : st.slices) {
    s.device_bytes += d.resident->bytes() + (d.film ? d.film->bytes() : 0) +
                      (d.estimator ? d.estimator->map_bytes() + d.estimator->state_bytes() : 0);
  }
  s.lights = resident.view().light_count;
  s.last_structure_build_ms = st.last_build_ms;
  return s;
}

}  // namespace caustica
