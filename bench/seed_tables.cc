#include "bench/seed_tables.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "bench/measure.h"
#include "bench/seed_flight.h"
#include "renderer/accel/build_options.h"
#include "renderer/accel/camera_tiles.h"
#include "renderer/accel/dacrt.h"
#include "renderer/accel/ray_queries.h"
#include "renderer/accel/traversal.h"
#include "renderer/base/rng.h"
#include "renderer/base/sampling.h"
#include "renderer/engine.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/load_scene.h"

namespace caustica {

namespace {

constexpr const char* kFabianowski = "Fabianowski 2011, Table 6.6";
constexpr const char* kZeidan = "Zeidan 2011, Tables 4.3-4.9";
constexpr const char* kRavichandran = "Ravichandran and Narayanan 2013, Tables 1 and 2";

std::filesystem::path scenes_dir(const BenchOptions& o) {
  return o.seed_scenes.empty() ? std::filesystem::path(CAUSTICA_SCENES_DIR) : o.seed_scenes;
}

// A JSON number, or null for a figure the seed did not print.
std::string number(std::optional<double> v) {
  return v ? absl::StrFormat("%.6g", *v) : std::string("null");
}

// How many times faster ours is: seed time over ours (null where either is missing).
std::optional<double> speedup(std::optional<double> seed_ms, std::optional<double> ours_ms) {
  if (!seed_ms || !ours_ms || *ours_ms <= 0.0) return std::nullopt;
  return *seed_ms / *ours_ms;
}

void unavailable(Reporter& report, const char* table, const std::string& row,
                 const std::string& why) {
  report.point("seed_table", row,
               absl::StrFormat(R"("table": "%s", "available": false, "why": "%s")", table, why));
}

// --- Fabianowski's Table 6.6: a frame under dynamic illumination -------------------------------

// A row of Table 6.6 (GTX 280, 512x512) with Table 5.1's emitted photons, its k_kNN (the k-nearest
// gather the thesis finds equal in quality to its kernel estimate) and k_VK (the kernels its
// variable kernel estimate sums per query, which ours takes as VKDE's k).
struct FlightRow {
  const char* scene;
  const char* folder;  // in scenes/; nullptr: not available
  uint32_t photons, k;
  double k_vk, interactions, trace_ms, lbvh_ms, render_ms, fps;
};

constexpr FlightRow kFlightRows[] = {
    {"Scene 6", nullptr, 131072, 301, 337.6, 163038, 10.53, 10.75, 264.77, 3.50},
    {"Sponza", "sponza", 262144, 155, 199.1, 299895, 55.95, 18.29, 201.51, 3.63},
    {"Sibenik", "sibenik", 524288, 201, 192.2, 416996, 102.47, 26.24, 197.08, 3.07},
    {"Fairy", nullptr, 131072, 75, 36.0, 9478, 14.93, 2.63, 34.27, 19.30},
    {"Conference", "conference", 131072, 201, 256.9, 82867, 29.14, 6.38, 228.89, 3.78},
    {"Passage", nullptr, 131072, 451, 459.6, 69083, 3.98, 5.84, 208.63, 4.58},
    {"Ring", "ring", 131072, 51, 186.6, 75525, 7.29, 6.46, 156.45, 5.88},
};

struct FlightTimes {
  double frame_ms = 0, trace_ms = 0, map_ms = 0, render_ms = 0, interactions = 0;
};

// Each frame of the flight: the camera and the lights moved, every photon re-traced, both maps
// rebuilt and one pass rendered, timed from the camera change to the finished pass. Returns the
// means over the flight, as the thesis averages its frames.
absl::StatusOr<FlightTimes> fly(Engine& engine, const std::vector<FlightFrame>& flight) {
  FlightTimes sum;
  for (const FlightFrame& frame : flight) {
    absl::Status failed;
    double trace = 0, map = 0, render = 0, interactions = 0;
    const double ms = engine.backend().time_ms([&] {
      const absl::StatusOr<RebuildReport> moved = engine.set_camera(frame.camera);
      const absl::StatusOr<RebuildReport> lit =
          moved.ok() ? engine.set_lights(frame.lights) : moved;
      const absl::StatusOr<PassReport> pass =
          lit.ok() ? engine.render(1) : absl::StatusOr<PassReport>(lit.status());
      if (!pass.ok()) {
        failed = pass.status();
        return;
      }
      trace = lit->timings.photon_trace_ms + pass->timings.photon_trace_ms;
      map = lit->timings.photon_map_build_ms + pass->timings.photon_map_build_ms;
      render = pass->timings.render_ms;
      interactions = double(lit->caustic_photons + lit->global_photons);
    });
    if (!failed.ok()) return failed;
    sum.frame_ms += ms;
    sum.trace_ms += trace;
    sum.map_ms += map;
    sum.render_ms += render;
    sum.interactions += interactions;
  }
  const double n = double(flight.size());
  return FlightTimes{sum.frame_ms / n, sum.trace_ms / n, sum.map_ms / n, sum.render_ms / n,
                     sum.interactions / n};
}

// The thesis's row flown with `estimator`: knn with its k_kNN, vkde (its own estimator) with its
// k_VK.
absl::Status flight_row(const BenchOptions& o, const FlightRow& row, EstimatorKind estimator,
                        Reporter& report) {
  const std::filesystem::path folder = scenes_dir(o) / row.folder;
  absl::StatusOr<Scene> scene = load_scene(folder / "scene.json");
  if (!scene.ok()) return scene.status();
  const int side = std::max(1, 512 / o.seed_reduce);
  const uint32_t photons = std::max<uint32_t>(1, row.photons / uint32_t(o.seed_reduce));
  scene->camera.width = scene->camera.height = side;
  scene->settings.photons_per_pass = photons;
  const uint32_t k = estimator == EstimatorKind::kVkde ? uint32_t(std::lround(row.k_vk)) : row.k;
  scene->settings.k_nearest = k;
  scene->settings.estimator = estimator;
  scene->settings.final_gather = false;
  absl::StatusOr<std::vector<FlightFrame>> flight =
      load_flight(folder / "flight.json", scene->camera, side, side);
  if (!flight.ok()) return flight.status();
  if (o.flight_frames > 0 && size_t(o.flight_frames) < flight->size())
    flight->resize(size_t(o.flight_frames));
  absl::StatusOr<std::shared_ptr<Backend>> backend = make_bench_backend(o);
  if (!backend.ok()) return backend.status();
  auto engine = Engine::create({.backend = *backend, .photons_per_leaf = o.photons_per_leaf});
  if (!engine.ok()) return engine.status();
  if (auto loaded = (*engine)->load(*scene); !loaded.ok()) return loaded.status();

  std::vector<FlightTimes> runs;
  for (int run = 0; run < o.warmup + o.runs; ++run) {
    absl::StatusOr<FlightTimes> times = fly(**engine, *flight);
    if (!times.ok()) return times.status();
    if (run >= o.warmup) runs.push_back(*times);
  }
  // The median flight by its frame time, with that flight's stages.
  std::sort(runs.begin(), runs.end(),
            [](const FlightTimes& a, const FlightTimes& b) { return a.frame_ms < b.frame_ms; });
  const FlightTimes& ours = runs[runs.size() / 2];
  const double fps = 1000.0 / ours.frame_ms;
  report.point(
      "seed_table", row.scene,
      absl::StrFormat(
          R"("table": "%s", "available": true, "seed_device": "GTX 280", "size": "%dx%d", )"
          R"("estimator": "%s", "photons": %u, "k": %u, "frames": %zu, "runs": %d, )"
          R"("seed": {"interactions": %.0f, "trace_ms": %g, "map_ms": %g, "render_ms": %g, "fps": %g}, )"
          R"("ours": {"interactions": %.0f, "trace_ms": %.4g, "map_ms": %.4g, "render_ms": %.4g, )"
          R"("frame_ms": %.4g, "fps": %.4g}, "speedup": %.4g)",
          kFabianowski, side, side, kind_name(estimator), photons, k, flight->size(), o.runs,
          row.interactions, row.trace_ms, row.lbvh_ms, row.render_ms, row.fps, ours.interactions,
          ours.trace_ms, ours.map_ms, ours.render_ms, ours.frame_ms, fps, fps / row.fps));
  return absl::OkStatus();
}

// --- The structures' tables: Zeidan's builders, Ravichandran and Narayanan's DACRT -------------

// A bundled scene (its own camera and lights) or a bare mesh (the ray benchmarks' framing camera
// and a light above it), uploaded.
struct SeedModel {
  std::string name;
  Scene scene;
  bool framed = false;  // a bare mesh: the camera frames it from outside
};

absl::StatusOr<SeedModel> load_model(const BenchOptions& o, const std::string& name,
                                     const std::filesystem::path& path, int side) {
  if (path.extension() == ".json") {
    absl::StatusOr<Scene> scene = load_scene(path);
    if (!scene.ok()) return scene.status();
    scene->camera.width = scene->camera.height = side;
    return SeedModel{name, *std::move(scene), false};
  }
  BenchOptions mesh = o;
  mesh.mesh = path;
  mesh.copies = 1;
  absl::StatusOr<Scene> scene = load_bench_mesh_scene(mesh);
  if (!scene.ok()) return scene.status();
  return SeedModel{name, *std::move(scene), true};
}

// Each pixel's primary hit: where it is and the triangle's normal facing the camera (zero for a
// miss), from which the secondary rays start.
void hit_frames(Backend& backend, const ResidentScene& resident, const PinholeCamera& camera,
                const Hit* hits, Buffer<Vec3f>& points, Buffer<Vec3f>& normals) {
  const size_t pixels = size_t(camera.width) * camera.height;
  points.resize_discard(pixels);
  normals.resize_discard(pixels);
  Vec3f* point = points.data();
  Vec3f* normal = normals.data();
  const TriangleVertices* triangles = resident.view().triangles;
  parallel_for(backend, "seed_hit_frames", pixels, [=] CAUSTICA_HD(size_t i) {
    const Hit h = hits[i];
    const Ray r =
        camera.ray_through(float(i % camera.width) + 0.5f, float(i / camera.width) + 0.5f);
    if (!h.valid()) {
      normal[i] = Vec3f(0.0f, 0.0f, 0.0f);
      return;
    }
    const TriangleVertices t = triangles[h.triangle];
    Vec3f n = normalize(cross(t.p1 - t.p0, t.p2 - t.p0));
    if (dot(n, r.direction) > 0.0f) n = -n;
    point[i] = r.origin + r.direction * h.t;
    normal[i] = n;
  });
}

// The three secondary ray sets of the fourth seed's Table 2 from the primary hits: a shadow ray
// to the point light, the mirror reflection, and eight cosine-distributed ambient-occlusion rays.
struct SecondaryRays {
  std::vector<Ray> shadow, specular, occlusion;
};

SecondaryRays secondary_rays(const PinholeCamera& camera, const std::vector<Vec3f>& points,
                             const std::vector<Vec3f>& normals, Vec3f light) {
  SecondaryRays rays;
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3f n = normals[i];
    if (n.x == 0.0f && n.y == 0.0f && n.z == 0.0f) continue;
    const Vec3f p = points[i];
    rays.shadow.push_back(shadow_ray(p + (light - p) * 1e-4f, light, 0.0f));
    const Vec3f d =
        camera.ray_through(float(i % camera.width) + 0.5f, float(i / camera.width) + 0.5f)
            .direction;
    const Vec3f mirrored = d - n * (2.0f * dot(d, n));
    rays.specular.push_back(Ray{offset_origin(p, n, mirrored), mirrored});
    const Frame frame = Frame::from_normal(n);
    for (uint32_t j = 0; j < 8; ++j) {
      Sampler s(11, uint32_t(i), j);
      const float u0 = s.next_float();
      const float u1 = s.next_float();
      const Vec3f w = frame.to_world(sample_cosine_hemisphere(u0, u1));
      rays.occlusion.push_back(Ray{offset_origin(p, n, w), w});
    }
  }
  return rays;
}

// The point light the shadow rays go to: the scene's first, or one above a bare mesh's box.
Vec3f shadow_light(const SeedModel& model, const Aabb& bounds) {
  if (!model.framed)
    for (const Light& light : model.scene.lights)
      if (light.type == LightType::kPoint) return light.position;
  return bounds.center() + Vec3f(0, length(bounds.extent()), 0);
}

// One of Zeidan's builders: the seed's figures per model (build ms, ray-cast ms, SAH cost), and
// the structure of ours that builds the same kind of tree.
struct BuilderColumn {
  const char* builder;
  StructureKind ours;
  // Toasters, Bunny, Dragon, Fairy Forest, Exploding Dragon.
  double build_ms[5], cast_ms[5], sah[5];
};

constexpr BuilderColumn kBuilders[] = {
    {"KD-tree (Zhou)",  // Table 4.3
     StructureKind::kKdSah,
     {41, 74, 104.6, 195.1, 195.1},
     {38, 71, 48.3, 94.9, 76.2},
     {128, 150, 184, 149, 171}},
    {"SAH BVH",  // Table 4.5
     StructureKind::kBinnedSah,
     {36.9, 144.3, 219.4, 522.4, 554},
     {21.3, 28.8, 23.1, 48, 38},
     {67, 61, 82.9, 55, 76}},
    {"LBVH",  // Table 4.6
     StructureKind::kLbvh4,
     {3, 8.5, 10.9, 10.9, 19.5},
     {28.3, 32.9, 28.3, 63.8, 46.7},
     {101.962, 72.6, 104, 61.4, 100}},
    {"hybrid SAH BVH",  // Table 4.7
     StructureKind::kHybrid,
     {10.9, 29.2, 56.5, 195.8, 127.4},
     {27.3, 32, 27.7, 52.3, 43.9},
     {99, 71, 102, 59.4, 96.7}},
    {"binned SAH BVH",  // Table 4.8
     StructureKind::kBinnedSah,
     {37.7, 47.4, 63.5, 94.6, 84},
     {28.3, 31, 27.3, 147.1, 38.5},
     {36, 63, 85.6, 58.6, 79}},
    {"hybrid binned SAH BVH",  // Table 4.9
     StructureKind::kHybrid,
     {29.6, 36.4, 43.2, 76.3, 74},
     {20, 31, 27.3, 153.2, 42.5},
     {40, 73, 92.6, 64.6, 89}},
};

struct ZeidanModel {
  const char* name;
  const char* seed_triangles;  // as the thesis rounds them
};
constexpr ZeidanModel kZeidanModels[] = {{"Toasters", "11K"},
                                         {"Bunny", "69K"},
                                         {"Dragon", "100K"},
                                         {"Fairy Forest", "178K"},
                                         {"Exploding Dragon", "252K"}};

// Zeidan's ray cast: the camera's rays as the renderer traces primary rays (camera_tiles.h).
template <typename View>
void cast_primary(Backend& backend, const View& view, const PinholeCamera& camera, Hit* hit) {
  trace_camera_tiles(
      backend, view, camera.origin, camera.width, camera.height,
      [=] CAUSTICA_HD(size_t i) {
        return camera.ray_through(float(i % camera.width) + 0.5f, float(i / camera.width) + 0.5f)
            .direction;
      },
      hit);
}

absl::Status zeidan_model(const BenchOptions& o, int index, const SeedModel& model,
                          Reporter& report) {
  absl::StatusOr<std::shared_ptr<Backend>> made = make_bench_backend(o);
  if (!made.ok()) return made.status();
  Backend& backend = **made;
  ResidentScene resident = ResidentScene::upload(backend, model.scene);
  const uint32_t tris = uint32_t(resident.triangle_count());
  const TriangleVertices* input = resident.view().triangles;
  const int side = std::max(1, 1024 / o.seed_reduce);
  const PinholeCamera camera = PinholeCamera::from(framing_camera(resident.bounds(), side, side));
  Buffer<Hit> hits(backend, size_t(side) * side);
  Hit* hit = hits.data();
  const BuildOptions build = apply_structure_options(o.structure_options, {});
  for (const BuilderColumn& column : kBuilders) {
    Measurement built = measure(
        o, backend, [&] { (void)build_structure(backend, column.ours, input, tris, build); });
    const TriangleStructure structure = build_structure(backend, column.ours, input, tris, build);
    Measurement cast = measure(o, backend, [&] {
      structure.visit([&](const auto& view) { cast_primary(backend, view, camera, hit); });
    });
    const double seed_total = column.build_ms[index] + column.cast_ms[index];
    report.point(
        "seed_table", absl::StrCat(model.name, " / ", column.builder),
        absl::StrFormat(
            R"("table": "%s", "available": true, "seed_device": "GTX 285", "size": "%dx%d", )"
            R"("structure": "%s", "seed_triangles": "%s", "triangles": %u, "runs": %d, )"
            R"("seed": {"build_ms": %g, "cast_ms": %g, "build_and_cast_ms": %g, "sah": %g}, )"
            R"("ours": {"build_ms": %.4g, "cast_ms": %.4g, "build_and_cast_ms": %.4g, "sah": %.4g}, )"
            R"("speedup": %.4g)",
            kZeidan, side, side, structure_kind_name(column.ours),
            kZeidanModels[index].seed_triangles, tris, o.runs, column.build_ms[index],
            column.cast_ms[index], seed_total, column.sah[index], built.median, cast.median,
            built.median + cast.median, structure.stats().sah_cost,
            seed_total / (built.median + cast.median)));
  }
  return absl::OkStatus();
}

// A row of the fourth seed's Tables 1 and 2 (GTX 580, 1024x1024): primary rays with the implicit
// structure's creation, then shadow, specular reflection and ambient-occlusion rays.
struct DacrtRow {
  const char* scene;
  std::optional<double> primary_ms, shadow_ms, specular_ms, occlusion_ms;
};

const DacrtRow kDacrtRows[] = {
    {"Bunny", 87, 67, 96, 149},
    {"Conference", 148, 197, 222, 240},
    {"Sponza", std::nullopt, 220, 246, 280},
    {"Angel", 143, 102, 163, 182},
    {"Dragon", 155, 128, 177, 192},
    {"Buddha", 165, 150, 190, 204},
    {"Turbine", 223, 213, 252, 287},
};

absl::Status dacrt_row(const BenchOptions& o, const DacrtRow& row, const SeedModel& model,
                       Reporter& report) {
  absl::StatusOr<std::shared_ptr<Backend>> made = make_bench_backend(o);
  if (!made.ok()) return made.status();
  Backend& backend = **made;
  ResidentScene resident = ResidentScene::upload(backend, model.scene);
  const uint32_t tris = uint32_t(resident.triangle_count());
  const TriangleVertices* input = resident.view().triangles;
  const int side = std::max(1, 1024 / o.seed_reduce);
  const Camera framed =
      model.framed ? framing_camera(resident.bounds(), side, side) : model.scene.camera;
  const PinholeCamera camera = PinholeCamera::from(framed);
  const size_t pixels = size_t(side) * side;
  const BuildOptions build = apply_structure_options(o.structure_options, {});
  const TriangleStructure dacrt =
      build_structure(backend, StructureKind::kDacrt, input, tris, build);

  Buffer<Ray> primary(backend, 0);
  queue_camera_rays(backend, camera, primary);
  Buffer<Hit> hits(backend, pixels);
  dacrt.visit(
      [&](const auto& view) { trace_closest(backend, view, primary.data(), pixels, hits.data()); });
  Buffer<Vec3f> points(backend, 0), normals(backend, 0);
  hit_frames(backend, resident, camera, hits.data(), points, normals);
  const SecondaryRays secondary = secondary_rays(camera, points.download(), normals.download(),
                                                 shadow_light(model, resident.bounds()));

  // Ours for each ray kind through DACRT (all its work per batch), then through the default
  // structure, built once, as a peer in the same process.
  struct Kind {
    const char* name;
    const Ray* rays;
    size_t count;
    bool any;
  };
  Buffer<Ray> shadow(backend, 0), specular(backend, 0), occlusion(backend, 0);
  shadow.upload(secondary.shadow);
  specular.upload(secondary.specular);
  occlusion.upload(secondary.occlusion);
  const Kind kinds[] = {{"primary", primary.data(), pixels, false},
                        {"shadow", shadow.data(), shadow.size(), true},
                        {"specular", specular.data(), specular.size(), false},
                        {"occlusion", occlusion.data(), occlusion.size(), false}};
  size_t most = 0;
  for (const Kind& kind : kinds) most = std::max(most, kind.count);
  Buffer<Hit> out(backend, most);
  Buffer<uint8_t> blocked(backend, most);
  const TriangleStructure peer = build_structure(backend, kDefaultStructure, input, tris, build);
  Measurement peer_build = measure(
      o, backend, [&] { (void)build_structure(backend, kDefaultStructure, input, tris, build); });
  auto trace = [&](const TriangleStructure& structure, const Kind& kind) {
    structure.visit([&](const auto& view) {
      if (kind.any)
        trace_any(backend, view, kind.rays, kind.count, blocked.data());
      else
        trace_closest(backend, view, kind.rays, kind.count, out.data());
    });
  };
  const std::optional<double> seed[] = {row.primary_ms, row.shadow_ms, row.specular_ms,
                                        row.occlusion_ms};
  std::string seed_fields, ours_fields, peer_fields, speedups, counts;
  for (size_t i = 0; i < 4; ++i) {
    const Kind& kind = kinds[i];
    Measurement ours = measure(o, backend, [&] { trace(dacrt, kind); });
    Measurement other = measure(o, backend, [&] { trace(peer, kind); });
    const char* sep = i == 0 ? "" : ", ";
    absl::StrAppendFormat(&seed_fields, R"(%s"%s_ms": %s)", sep, kind.name, number(seed[i]));
    absl::StrAppendFormat(&ours_fields, R"(%s"%s_ms": %.4g)", sep, kind.name, ours.median);
    absl::StrAppendFormat(&peer_fields, R"(%s"%s_ms": %.4g)", sep, kind.name, other.median);
    absl::StrAppendFormat(&speedups, R"(%s"%s": %s)", sep, kind.name,
                          number(speedup(seed[i], ours.median)));
    absl::StrAppendFormat(&counts, R"(%s"%s": %zu)", sep, kind.name, kind.count);
  }
  report.point(
      "seed_table", row.scene,
      absl::StrFormat(
          R"("table": "%s", "available": true, "seed_device": "GTX 580", "size": "%dx%d", )"
          R"("triangles": %u, "runs": %d, "rays": {%s}, "seed": {%s}, "ours": {%s}, )"
          R"("peer": {"structure": "%s", "build_ms": %.4g, %s}, "speedup": {%s})",
          kRavichandran, side, side, tris, o.runs, counts, seed_fields, ours_fields,
          structure_kind_name(kDefaultStructure), peer_build.median, peer_fields, speedups));
  return absl::OkStatus();
}

// The models of the structures' tables: what the repository has of each, by the seeds' names.
std::optional<std::filesystem::path> model_path(const BenchOptions& o, const std::string& name) {
  const std::filesystem::path scenes = scenes_dir(o);
  if (name == "Bunny") return scenes / "bunny" / "bunny.ply";
  if (name == "Dragon" && !o.dragon.empty()) return o.dragon;
  if (name == "Conference") return scenes / "conference" / "scene.json";
  if (name == "Sponza") return scenes / "sponza" / "scene.json";
  return std::nullopt;
}

std::string missing_model(const std::string& name) {
  if (name == "Dragon") return "give the Stanford dragon with --dragon (scripts/fetch-dragon)";
  if (name == "Exploding Dragon") return "an animation of the dragon, not in the repository";
  return "not in the repository";
}

}  // namespace

std::vector<std::string> seed_table_names() { return {kFabianowski, kZeidan, kRavichandran}; }

absl::Status seed_tables(const BenchOptions& o, Reporter& report) {
  for (const FlightRow& row : kFlightRows) {
    if (row.folder == nullptr) {
      unavailable(report, kFabianowski, row.scene, "not in the repository");
      continue;
    }
    for (EstimatorKind estimator : {EstimatorKind::kKnn, EstimatorKind::kVkde}) {
      if (absl::Status s = flight_row(o, row, estimator, report); !s.ok()) return s;
    }
  }
  // The bunny and the dragon serve both structure tables: each is loaded once.
  const int side = std::max(1, 1024 / o.seed_reduce);
  std::map<std::string, SeedModel, std::less<>> loaded;
  auto model_named = [&](const std::string& name,
                         const std::filesystem::path& path) -> absl::StatusOr<const SeedModel*> {
    auto it = loaded.find(name);
    if (it == loaded.end()) {
      absl::StatusOr<SeedModel> model = load_model(o, name, path, side);
      if (!model.ok()) return model.status();
      it = loaded.emplace(name, *std::move(model)).first;
    }
    return &it->second;
  };
  for (int i = 0; i < int(std::size(kZeidanModels)); ++i) {
    const std::string name = kZeidanModels[i].name;
    const std::optional<std::filesystem::path> path = model_path(o, name);
    if (!path) {
      unavailable(report, kZeidan, name, missing_model(name));
      continue;
    }
    absl::StatusOr<const SeedModel*> model = model_named(name, *path);
    if (!model.ok()) return model.status();
    if (absl::Status s = zeidan_model(o, i, **model, report); !s.ok()) return s;
  }
  for (const DacrtRow& row : kDacrtRows) {
    const std::optional<std::filesystem::path> path = model_path(o, row.scene);
    if (!path) {
      unavailable(report, kRavichandran, row.scene, missing_model(row.scene));
      continue;
    }
    absl::StatusOr<const SeedModel*> model = model_named(row.scene, *path);
    if (!model.ok()) return model.status();
    if (absl::Status s = dacrt_row(o, row, **model, report); !s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace caustica
