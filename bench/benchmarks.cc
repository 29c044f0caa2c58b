#include "bench/benchmarks.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <stdexcept>
#include <type_traits>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "bench/convergence.h"
#include "bench/measure.h"
#include "bench/multi_device.h"
#include "bench/seed_tables.h"
#include "bench/serving.h"
#include "renderer/accel/camera_tiles.h"
#include "renderer/accel/dacrt.h"
#include "renderer/accel/ray_queries.h"
#include "renderer/accel/traversal.h"
#include "renderer/base/pixel_blocks.h"
#include "renderer/base/rng.h"
#include "renderer/base/sampling.h"
#include "renderer/engine.h"
#include "renderer/estimator/knn_gather.h"
#include "renderer/estimator/vkde_estimator.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/knn_estimate.h"
#include "renderer/photon/photon_map.h"
#include "renderer/photon/photon_tracer.h"
#include "renderer/photon/vkde_photons.h"
#include "renderer/photon/volume_map.h"
#include "renderer/render/camera.h"
#include "renderer/render/path_tracer.h"
#include "renderer/render/whitted.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/load_scene.h"

namespace caustica {

absl::StatusOr<Scene> load_bench_mesh_scene(const BenchOptions& o) {
  if (o.mesh.extension() == ".json") return load_scene(o.mesh);
  std::vector<std::string> shapes;
  for (int i = 0; i < o.copies; ++i)
    shapes.push_back(absl::StrFormat(
        R"({"type": "mesh", "file": "%s", "material": "white", "transform": {"translate": [%g, %g, 0]}})",
        std::filesystem::absolute(o.mesh).string(), 0.25 * i, 0.15 * i));
  return parse_scene(absl::StrFormat(R"({
    "camera": {"position": [0, 0, 1], "look_at": [0, 0, 0], "fov": 45, "width": %d, "height": %d},
    "materials": {"white": {"type": "diffuse", "albedo": [0.8, 0.8, 0.8]}},
    "lights": [{"type": "point", "position": [0, 100, 0], "intensity": [1, 1, 1]}],
    "shapes": [%s]})",
                                     o.width, o.height, absl::StrJoin(shapes, ", ")),
                     ".", "benchmark mesh scene");
}

// At the box centre + (0, 0, 2 x diagonal), with a field of view that fits the larger of the x and
// y extents plus a 5% margin.
Camera framing_camera(const Aabb& b, int width, int height) {
  Vec3f c = b.center(), e = b.extent();
  float distance = 2.0f * length(e);
  float half = 0.5f * 1.05f * std::max(e.x, e.y);
  Camera cam;
  cam.position = c + Vec3f(0, 0, distance);
  cam.look_at = c;
  cam.vertical_fov_deg = 2.0f * std::atan(half / distance) * 180.0f / kPi;
  cam.width = width;
  cam.height = height;
  return cam;
}

absl::StatusOr<std::shared_ptr<Backend>> make_bench_backend(const BenchOptions& o) {
  absl::StatusOr<DeviceKind> kind = parse_device_kind(o.device);
  if (!kind.ok()) return kind.status();
  return make_backend(*kind, size_t(16) << 30);
}

void queue_camera_rays(Backend& backend, const PinholeCamera& camera, Buffer<Ray>& rays) {
  const size_t pixels = size_t(camera.width) * camera.height;
  rays.resize_discard(pixels);
  Ray* ray = rays.data();
  parallel_for(backend, "camera_ray_queue", pixels, [=] CAUSTICA_HD(size_t i) {
    ray[i] = camera.ray_through(float(i % camera.width) + 0.5f, float(i / camera.width) + 0.5f);
  });
}

namespace {

// For dacrt, what one batch of the rays held at most in scratch memory (what it uses instead of a
// stored structure), reported as `label`; other structures trace in none.
template <typename Structure>
void report_batch_scratch(Backend& backend, const Structure& view, const Ray* rays, size_t count,
                          const char* label, const std::string& name, Reporter& report) {
  if constexpr (std::is_same_v<Structure, DacrtView>) {
    Buffer<Hit> hits(backend, count);
    DacrtTraceStats stats;
    trace_closest(backend, view, rays, count, hits.data(), &stats);
    report.line(label, name, double(stats.peak_scratch_bytes), "B");
    report.line("dacrt_triangle_tests_per_ray", name, double(stats.triangle_tests) / count,
                "tests/ray");
    report.line("dacrt_levels", name, double(stats.levels), "levels");
  }
}

// The primary rays one per thread through a per-ray view (StructureView).
template <typename Structure>
void trace_primary_single(Backend& backend, const Structure& bvh, const PinholeCamera& camera,
                          Hit* hit) {
  const size_t pixels = size_t(camera.width) * camera.height;
  parallel_for(backend, "primary_rays_single", pixels, [=] CAUSTICA_HD(size_t i) {
    hit[i] = closest_hit(
        bvh, camera.ray_through(float(i % camera.width) + 0.5f, float(i / camera.width) + 0.5f));
  });
}

// Shadow rays repeated eight times in one launch, for a per-ray view on a GPU.
template <typename Structure>
void trace_shadow_repeated(Backend& backend, const Structure& bvh, const Ray* ray, size_t count,
                           uint8_t* out) {
  parallel_for(backend, "shadow_rays_repeated", 8 * count,
               [=] CAUSTICA_HD(size_t i) { out[i % count] = any_hit(bvh, ray[i % count]); });
}

// The incoherent rays (origins uniform in `b`, directions uniform on the sphere), queued.
void queue_incoherent_rays(Backend& backend, const Aabb& b, size_t count, Buffer<Ray>& rays) {
  rays.resize_discard(count);
  Ray* ray = rays.data();
  parallel_for(backend, "incoherent_ray_queue", count, [=] CAUSTICA_HD(size_t i) {
    Sampler s(7, uint32_t(i), 0);
    Ray r;
    r.origin = b.lower + b.extent() * Vec3f(s.next_float(), s.next_float(), s.next_float());
    r.direction = sample_uniform_sphere(s.next_float(), s.next_float());
    ray[i] = r;
  });
}

// The same rays made and traced in one launch through a per-ray view.
template <typename Structure>
void trace_incoherent_single(Backend& backend, const Structure& bvh, size_t count, Hit* hit) {
  const Aabb b = bvh.bounds;
  parallel_for(backend, "incoherent_rays", count, [=] CAUSTICA_HD(size_t i) {
    Sampler s(7, uint32_t(i), 0);
    Ray r;
    r.origin = b.lower + b.extent() * Vec3f(s.next_float(), s.next_float(), s.next_float());
    r.direction = sample_uniform_sphere(s.next_float(), s.next_float());
    hit[i] = closest_hit(bvh, r);
  });
}

// The ray benchmarks through `bvh`, the view of the structure under test (any
// BatchStructureView). Per-ray views are also measured one ray per thread, as before the queues;
// the *_batch lines go through trace_closest and trace_any, which is all a batch-only view
// (dacrt) answers and which for it includes all its per-frame work.
template <typename Structure>
void ray_benchmarks(const BenchOptions& o, Backend* backend, const Structure& bvh,
                    const std::string& name, Reporter& report) {
  constexpr bool kPerRay = StructureView<Structure>;
  const PinholeCamera camera = PinholeCamera::from(framing_camera(bvh.bounds, o.width, o.height));
  const size_t pixels = size_t(o.width) * o.height;
  Buffer<Hit> hits(*backend, pixels);
  Hit* hit = hits.data();
  Buffer<Ray> queued(*backend, 0);
  auto trace_primary = [&] {
    if constexpr (kPerRay) {
      trace_primary_single(*backend, bvh, camera, hit);
    } else {
      queue_camera_rays(*backend, camera, queued);
      trace_closest(*backend, bvh, queued.data(), pixels, hit);
    }
  };
  if (wanted(o, "primary_rays")) {
    // Camera rays in square tiles traced as packets (what the renderer does for primary rays), and
    // the same rays one at a time.
    Measurement m = measure(o, *backend, [&] {
      trace_camera_tiles(
          *backend, bvh, camera.origin, camera.width, camera.height,
          [=] CAUSTICA_HD(size_t i) {
            return camera
                .ray_through(float(i % camera.width) + 0.5f, float(i / camera.width) + 0.5f)
                .direction;
          },
          hit);
    });
    report.line("primary_rays", name, pixels / (m.median * 1e3), "Mrays/s", &m, o.runs);
    if constexpr (kPerRay) {
      Measurement single = measure(o, *backend, trace_primary);
      report.line("primary_rays_single", name, pixels / (single.median * 1e3), "Mrays/s", &single,
                  o.runs);
    }
    // The camera's rays already queued, through trace_closest alone: with dacrt this is the
    // whole per-frame work of tracing them (the issue's target is the dragon at 1024x1024).
    queue_camera_rays(*backend, camera, queued);
    Measurement batch =
        measure(o, *backend, [&] { trace_closest(*backend, bvh, queued.data(), pixels, hit); });
    report.line("primary_rays_batch", name, pixels / (batch.median * 1e3), "Mrays/s", &batch,
                o.runs);
    batch.kernels.clear();  // reported with the line above
    report.line("primary_rays_batch_ms", name, batch.median, "ms", &batch, o.runs);
    report_batch_scratch(*backend, bvh, queued.data(), pixels, "primary_rays_scratch_bytes", name,
                         report);
  } else if (wanted(o, "shadow_rays")) {
    trace_primary();
  }
  if (wanted(o, "shadow_rays")) {
    // Between every primary hit and a point light above the box: any-hit rays, made as the
    // renderer makes them (from the light's end, shadow_ray) and first, in the order the renderer
    // would launch them (image blocks of 8x4, misses left out), so that only their tracing is
    // timed.
    const Vec3f light = bvh.bounds.center() + Vec3f(0, length(bvh.bounds.extent()), 0);
    const std::vector<Ray> shadow_list = [&] {
      std::vector<Hit> h = hits.download();
      std::vector<Ray> rays;
      const PixelBlocks blocks(camera.width, camera.height);
      for (size_t thread = 0; thread < blocks.thread_count(); ++thread) {
        size_t pixel;
        if (!blocks.pixel_of(thread, pixel) || !h[pixel].valid()) continue;
        Ray primary = camera.ray_through(float(pixel % camera.width) + 0.5f,
                                         float(pixel / camera.width) + 0.5f);
        Vec3f p = primary.origin + primary.direction * h[pixel].t;
        rays.push_back(shadow_ray(p + (light - p) * 1e-4f, light, 0.0f));
      }
      return rays;
    }();
    Buffer<Ray> shadow_rays(*backend, shadow_list.size());
    shadow_rays.upload(shadow_list);
    Buffer<uint8_t> blocked(*backend, shadow_list.size());
    const Ray* ray = shadow_rays.data();
    uint8_t* out = blocked.data();
    Measurement m =
        measure(o, *backend, [&] { trace_any(*backend, bvh, ray, shadow_list.size(), out); });
    report.line("shadow_rays", name, shadow_list.size() / (m.median * 1e3), "Mrays/s", &m, o.runs);
    if constexpr (kPerRay) {
      if (backend->kind() == DeviceKind::kCuda) {
        // The same rays eight times over in one launch: the GPU's rate once the start and the
        // drain of a launch, where the warps whose rays cost the most finish alone, weigh an
        // eighth as much.
        const size_t count = shadow_list.size();
        Measurement repeated =
            measure(o, *backend, [&] { trace_shadow_repeated(*backend, bvh, ray, count, out); });
        report.line("shadow_rays_repeated", name, 8 * count / (repeated.median * 1e3), "Mrays/s",
                    &repeated, o.runs);
      }
    }
  }
  if (wanted(o, "incoherent_rays")) {
    // Origins uniform in the box, directions uniform on the sphere: no coherence at all.
    const size_t count = pixels;
    Measurement m = measure(o, *backend, [&] {
      if constexpr (kPerRay) {
        trace_incoherent_single(*backend, bvh, count, hit);
      } else {
        queue_incoherent_rays(*backend, bvh.bounds, count, queued);
        trace_closest(*backend, bvh, queued.data(), count, hit);
      }
    });
    report.line("incoherent_rays", name, count / (m.median * 1e3), "Mrays/s", &m, o.runs);
  }
}

absl::Status mesh_benchmarks(const BenchOptions& o, Reporter& all) {
  absl::StatusOr<Scene> scene = load_bench_mesh_scene(o);
  if (!scene.ok()) return scene.status();
  // A scene file is named by its folder, as the photon benchmarks name theirs.
  const std::string file = o.mesh.extension() == ".json" ? o.mesh.parent_path().filename().string()
                                                         : o.mesh.filename().string();
  const std::string name = file + (o.copies > 1 ? absl::StrFormat(" x%d", o.copies) : "");
  absl::StatusOr<std::shared_ptr<Backend>> made = make_bench_backend(o);
  if (!made.ok()) return made.status();
  Backend* backend = made->get();
  ResidentScene resident = ResidentScene::upload(*backend, *scene);
  const uint32_t tris = uint32_t(resident.triangle_count());
  const TriangleVertices* input = resident.view().triangles;

  if (wanted(o, "lbvh_build")) {
    // The LBVH alone (codes, sort, hierarchy with bounds), which every structure's build is
    // measured against.
    Measurement m = measure(o, *backend, [&] { build_triangle_lbvh(*backend, input, tris); });
    all.line("lbvh_build", name, tris / (m.median * 1e3), "Mtris/s", &m, o.runs);
  }
  const BuildOptions build = apply_structure_options(o.structure_options, {});
  for (StructureKind kind : o.structures) {
    Reporter report = all.for_structure(structure_kind_name(kind));
    TriangleStructure built = resident.new_structure(kind, build);
    resident.swap_structure(built);
    built = TriangleStructure();  // the previous kind's, not kept while this one is measured
    if (wanted(o, "lbvh_build")) {
      // Everything the structure's traversal reads, built from the triangles in memory.
      Measurement s =
          measure(o, *backend, [&] { (void)build_structure(*backend, kind, input, tris, build); });
      report.line("structure_build", name, tris / (s.median * 1e3), "Mtris/s", &s, o.runs);
      s.kernels.clear();  // reported with the line above
      report.line("structure_build_ms", name, s.median, "ms", &s, o.runs);
    }
    const StructureStats& stats = resident.structure().stats();
    report.line("triangle_structure_bytes_per_triangle", name, double(stats.bytes) / tris, "B/tri");
    report.line("structure_sah_cost", name, stats.sah_cost, "SAH");
    resident.structure().visit(
        [&](const auto& view) { ray_benchmarks(o, backend, view, name, report); });
  }
  return absl::OkStatus();
}

// The heap gathers alone at `count` points with their normals, one point per thread, as the render
// pass makes them below the counting gathers' k (render/whitted.cc).
struct GatherAtPoints {
  PhotonMapView map;
  const Vec3f* points;
  const Vec3f* normals;
  Vec3f* out;
  uint32_t k;
  float max_radius;
  DensityKernel kernel;

  template <typename Scratch>
  CAUSTICA_HDI void operator()(size_t i, Scratch scratch) const {
    out[i] =
        estimate_radiance(map, points[i], normals[i], Vec3f(1.0f), k, max_radius, kernel, scratch);
  }
};

constexpr const char* photon_map_nodes_name(PhotonMapNodes nodes) {
  return nodes == PhotonMapNodes::kSiblingPairs ? "sibling-pairs" : "box-pairs";
}

// The photon maps' two node layouts (PhotonMapNodes) under the same photons: the gathers alone at
// the global map's photons (in its curve order, each facing its photon's arrival), and the render
// pass on maps of each layout, which gathers as the renderer does on each device.
absl::Status photon_gather_benchmarks(const BenchOptions& o, const Scene& scene,
                                      const std::shared_ptr<Backend>& shared,
                                      const ResidentScene& resident, uint32_t per_leaf,
                                      const std::string& name, Reporter& report) {
  Backend* backend = shared.get();
  auto engine = Engine::create({.backend = shared, .photons_per_leaf = o.photons_per_leaf});
  if (!engine.ok()) return engine.status();
  if (auto loaded = (*engine)->load(scene); !loaded.ok()) return loaded.status();
  const RenderSettings& rs = scene.settings;
  const ShadingSettings shading = (*engine)->shading(0);
  const uint32_t k = std::min(shading.k_nearest, kMaxNearest);
  const TracedPhotons traced =
      trace_photons(*backend, resident, photon_trace_settings(rs, o.photons, 0));
  const std::vector<Photon> at = build_photon_map(*backend, traced.global, per_leaf).download();
  if (at.empty()) return absl::FailedPreconditionError(name + ": no global photons to gather at");
  std::vector<Vec3f> points(at.size()), normals(at.size());
  for (size_t i = 0; i < at.size(); ++i) {
    points[i] = at[i].position;
    normals[i] = -at[i].incoming;
  }
  Buffer<Vec3f> point_buffer(*backend, points.size()), normal_buffer(*backend, normals.size()),
      out(*backend, points.size());
  point_buffer.upload(points);
  normal_buffer.upload(normals);
  Film film(*backend, o.width, o.height);
  const PinholeCamera camera = PinholeCamera::from(scene.camera);
  for (PhotonMapNodes nodes : {PhotonMapNodes::kBoxPairs, PhotonMapNodes::kSiblingPairs}) {
    const PhotonMap caustic = build_photon_map(*backend, traced.caustic, per_leaf, nodes);
    const PhotonMap global = build_photon_map(*backend, traced.global, per_leaf, nodes);
    const std::string label = name + absl::StrFormat(" k=%d %s", k, photon_map_nodes_name(nodes));
    const GatherAtPoints gather{
        global.view(),      point_buffer.data(), normal_buffer.data(), out.data(), k,
        shading.max_radius, shading.kernel};
    const uint32_t heap_pairs = NeighbourHeap<NeighbourPair*>::pairs_for(k);
    bool fits = true;
    Measurement m = measure(o, *backend, [&] {
      fits = parallel_for_with_scratch<NeighbourPair>(*backend, "photon_gather", points.size(),
                                                      heap_pairs, gather);
    });
    if (!fits) return absl::ResourceExhaustedError(label + ": no room for the heaps' scratch");
    report.line("photon_gather", label + absl::StrFormat(" %zu points", points.size()),
                points.size() / (m.median * 1e3), "Mgathers/s", &m, o.runs);
    report.line("photon_map_node_bytes_per_photon", label,
                double(caustic.bvh.nodes.bytes() + caustic.pair_nodes.bytes() +
                       global.bvh.nodes.bytes() + global.pair_nodes.bytes()) /
                    double(caustic.size() + global.size()),
                "B/photon");
    uint32_t pass = 0;
    Measurement pass_m = measure(o, *backend, [&] {
      render_pass(*backend, resident, camera, (*engine)->shading(pass++),
                  KnnGather(caustic, global), film);
    });
    report.line("photon_gather_render_pass",
                label + absl::StrFormat(" %dx%d", scene.camera.width, scene.camera.height),
                pass_m.median, "ms", &pass_m, o.runs);
  }
  return absl::OkStatus();
}

absl::Status photon_benchmarks(const BenchOptions& o, StructureKind structure, Reporter& report) {
  absl::StatusOr<Scene> scene = load_scene(o.photon_scene);
  if (!scene.ok()) return scene.status();
  scene->settings.structure = structure;
  scene->settings.build = apply_structure_options(o.structure_options, scene->settings.build);
  const std::string name = o.photon_scene.parent_path().filename().string();
  absl::StatusOr<std::shared_ptr<Backend>> made = make_bench_backend(o);
  if (!made.ok()) return made.status();
  Backend* backend = made->get();
  ResidentScene resident = ResidentScene::upload(*backend, *scene);
  // The maps' leaves as the engine makes them for this device and k, unless asked otherwise.
  const uint32_t per_leaf = photons_per_leaf_for(backend->kind(), o.k, o.photons_per_leaf);

  if (wanted(o, "photon_pass")) {
    // The whole light-change pipeline up to the maps, then its two halves on their own, with the
    // scene's path length cap and seed, as the engine traces them.
    uint32_t pass = 0;
    size_t stored = 0, map_bytes = 0;
    PhotonTraceSettings trace = photon_trace_settings(scene->settings, o.photons, 0);
    trace.ray_queues = o.ray_queues;
    Measurement m = measure(o, *backend, [&] {
      PhotonTraceSettings this_pass = trace;
      this_pass.pass = pass++;
      TracedPhotons traced = trace_photons(*backend, resident, this_pass);
      const PhotonMapPair maps =
          build_photon_maps(*backend, traced.caustic, traced.global, per_leaf);
      stored = maps.first.size() + maps.second.size();
      map_bytes = maps.first.bytes() + maps.second.bytes();
    });
    const std::string label = name + absl::StrFormat(" %d photons", o.photons);
    report.line("photon_pass", label, m.median, "ms", &m, o.runs);
    Measurement traced_only =
        measure(o, *backend, [&] { (void)trace_photons(*backend, resident, trace); });
    report.line("photon_trace", label, traced_only.median, "ms", &traced_only, o.runs);
    // The same trace tracking photon differentials, each stored photon with its footprint.
    PhotonTraceSettings with_differentials = trace;
    with_differentials.differentials = true;
    Measurement differentials =
        measure(o, *backend, [&] { (void)trace_photons(*backend, resident, with_differentials); });
    report.line("photon_trace_differentials", label, differentials.median, "ms", &differentials,
                o.runs);
    // VKDE's whole preparation of a pass (estimator/vkde_estimator.h): the trace with
    // differentials, the kernels and the hierarchy over their supports; then its two steps after
    // the trace on their own.
    EstimatorOptions vkde_options;
    vkde_options.kind = EstimatorKind::kVkde;
    vkde_options.k_nearest = o.k;
    VkdeEstimator vkde(vkde_options);
    Measurement vkde_pass = measure(o, *backend, [&] {
      PhotonTraceSettings this_pass = with_differentials;
      this_pass.pass = pass++;
      vkde.prepare(*backend, resident, trace_photons(*backend, resident, this_pass),
                   this_pass.pass);
      vkde.drop_maps();
    });
    report.line("vkde_photon_pass", label, vkde_pass.median, "ms", &vkde_pass, o.runs);
    const TracedPhotons with_footprints = trace_photons(*backend, resident, with_differentials);
    const VkdeSettings kernel_settings = vkde_settings(vkde_options, resident.radius());
    Measurement kernels = measure(
        o, *backend, [&] { (void)make_vkde_kernels(*backend, with_footprints, kernel_settings); });
    const VkdeKernels made = make_vkde_kernels(*backend, with_footprints, kernel_settings);
    report.line(
        "vkde_kernels",
        label + absl::StrFormat(" %zu kept, %u discarded", made.kernels.size(), made.discarded),
        kernels.median, "ms", &kernels, o.runs);
    const double covering = made.support_area / resident.surface_area();
    const uint32_t leaf_size =
        kernel_leaf_size(made.support_area, resident.surface_area(), kVkdeLeafScale);
    Measurement kernel_map =
        measure(o, *backend, [&] { (void)build_kernel_map(*backend, made.kernels, leaf_size); });
    report.line(
        "kernel_map_build",
        label + absl::StrFormat(" %zu kernels, leaves of %u", made.kernels.size(), leaf_size),
        kernel_map.median, "ms", &kernel_map, o.runs);
    // Fabianowski's k_VK: the kernels expected to cover a point of the scene's surfaces.
    report.line("vkde_kernels_per_point", name, covering, "kernels");
    TracedPhotons traced = trace_photons(*backend, resident, trace);
    // The paths the scene's max_photon_bounces ended, roulette not: each traced to the cap, for
    // none of its light in the maps (docs/performance.md, "The light change").
    report.line("photon_paths_capped", label, double(traced.capped_paths), "paths");
    report.line("photon_paths_specular_capped", label, double(traced.specular_capped_paths),
                "paths");
    Measurement maps = measure(o, *backend, [&] {
      (void)build_photon_maps(*backend, traced.caustic, traced.global, per_leaf);
    });
    report.line("photon_maps_build", label + absl::StrFormat(" %zu stored", stored), maps.median,
                "ms", &maps, o.runs);
    report.line("photon_map_bytes_per_photon", name, stored ? double(map_bytes) / stored : 0.0,
                "B/photon");
  }
  if (wanted(o, "frame")) {
    scene->camera.width = o.width;
    scene->camera.height = o.height;
    scene->settings.k_nearest = o.k;
    scene->settings.photons_per_pass = o.photons;
    scene->settings.estimator = o.estimator;
    scene->settings.final_gather = o.final_gather;
    apply_final_gather_options(o, scene->settings);
    auto engine = Engine::create({.backend = *made, .photons_per_leaf = o.photons_per_leaf});
    if (!engine.ok()) return engine.status();
    if (auto loaded = (*engine)->load(*scene); !loaded.ok()) return loaded.status();
    Measurement m = measure(o, (*engine)->backend(), [&] { (void)(*engine)->render(1); });
    report.line(
        "frame",
        name + absl::StrFormat(" %dx%d k=%d %s", o.width, o.height, o.k, kind_name(o.estimator)),
        m.median, "ms", &m, o.runs);
    // Light change to finished frame: new lights, then one pass (photons, maps, render), with the
    // engine's own stage times of each call, as the server reports them to update_to_frame.
    std::vector<Light> lights = scene->lights;
    std::vector<double> trace_ms, map_ms, render_ms;
    int step = 0;
    Measurement change = measure(o, (*engine)->backend(), [&] {
      const absl::StatusOr<RebuildReport> rebuilt =
          (*engine)->set_lights(lights, {}, turned_environment(*scene, step++));
      const absl::StatusOr<PassReport> pass = (*engine)->render(1);
      if (!rebuilt.ok() || !pass.ok()) return;
      trace_ms.push_back(rebuilt->timings.photon_trace_ms + pass->timings.photon_trace_ms);
      map_ms.push_back(rebuilt->timings.photon_map_build_ms + pass->timings.photon_map_build_ms);
      render_ms.push_back(pass->timings.render_ms);
    });
    const std::string change_label = name + " " + kind_name(o.estimator);
    report.line("light_change_to_frame", change_label, change.median, "ms", &change, o.runs);
    // The warm-up runs' times are left out, as measure leaves them out of `change`.
    for (auto* times : {&trace_ms, &map_ms, &render_ms})
      times->erase(times->begin(), times->begin() + std::min<size_t>(o.warmup, times->size()));
    if (trace_ms.empty()) return absl::InternalError("the light change or its pass failed");
    report.line("light_change_photon_trace", change_label, summarize(trace_ms).median, "ms");
    report.line("light_change_photon_map_build", change_label, summarize(map_ms).median, "ms");
    report.line("light_change_render", change_label, summarize(render_ms).median, "ms");

    // The k-nearest render pass alone on maps already built: camera rays, specular chains, shadow
    // rays and both gathers, as the frame target counts it.
    const RenderSettings& rs = scene->settings;
    PhotonTraceSettings trace = photon_trace_settings(rs, o.photons, 0);
    trace.ray_queues = o.ray_queues;
    TracedPhotons traced = trace_photons(*backend, resident, trace);
    PhotonMapPair maps = build_photon_maps(*backend, traced.caustic, traced.global, per_leaf);
    PhotonMap& caustic = maps.first;
    PhotonMap& global = maps.second;
    // In a scene with media, the volume map the beam estimate reads, as the knn estimator builds
    // it.
    const float max_bandwidth = volume_bandwidth_cap(resident.bounds());
    VolumeMap volume =
        build_volume_map(*backend, traced.volume, per_leaf, kVolumeNearest, max_bandwidth);
    if (!traced.volume.empty()) {
      Measurement volume_build = measure(o, *backend, [&] {
        (void)build_volume_map(*backend, traced.volume, per_leaf, kVolumeNearest, max_bandwidth);
      });
      report.line("volume_map_build", name + absl::StrFormat(" %zu collisions", volume.size()),
                  volume_build.median, "ms", &volume_build, o.runs);
    }
    Film film(*backend, o.width, o.height);
    const PinholeCamera camera = PinholeCamera::from(scene->camera);
    uint32_t pass = 0, requests = 0;
    Measurement gather = measure(o, *backend, [&] {
      ShadingSettings shading = (*engine)->shading(pass++);
      shading.ray_queues = o.ray_queues;
      shading.volume = volume.view();
      if (o.branch_survival >= 0.0f) shading.branch_survival = o.branch_survival;
      render_pass(*backend, resident, camera, shading, KnnGather(caustic, global), film, &requests);
    });
    const std::string label = name + absl::StrFormat(" %dx%d k=%d", o.width, o.height, o.k);
    report.line("frame_render", label, gather.median, "ms", &gather, o.runs);
    // Of the last pass: the diffuse hits the gathers estimated, per pixel.
    report.line("gather_requests_per_pixel", label, double(requests) / (double(o.width) * o.height),
                "requests");
  }
  if (wanted(o, "geometry_change")) {
    // A mesh moved, to the finished frame: the scene's largest mesh turned a little further
    // about its centre each run (set_geometry: the geometry uploaded, the structure built again,
    // the photons traced and their maps built), then one pass; with the engine's stage times.
    Scene moving = *scene;
    moving.camera.width = o.width;
    moving.camera.height = o.height;
    moving.settings.k_nearest = o.k;
    moving.settings.photons_per_pass = o.photons;
    moving.settings.estimator = o.estimator;
    size_t largest = 0;
    for (size_t i = 0; i < moving.meshes.size(); ++i) {
      if (moving.meshes[i].indices.size() > moving.meshes[largest].indices.size()) largest = i;
    }
    const Mesh& mesh = moving.meshes[largest];
    Vec3f centre(0.0f);
    for (const Vec3f& p : mesh.positions) centre += p;
    centre = centre / float(std::max<size_t>(mesh.positions.size(), 1));
    auto engine = Engine::create({.backend = *made, .photons_per_leaf = o.photons_per_leaf});
    if (!engine.ok()) return engine.status();
    if (auto loaded = (*engine)->load(moving); !loaded.ok()) return loaded.status();
    std::vector<double> build_ms, trace_ms, map_ms, render_ms;
    size_t refitted = 0;
    int step = 0;
    Measurement change = measure(o, (*engine)->backend(), [&] {
      const MeshChange turned{
          mesh.name,
          translation(centre) * rotation_y_deg(++step) * translation(Vec3f(0.0f) - centre),
          std::nullopt, std::nullopt};
      const absl::StatusOr<RebuildReport> rebuilt = (*engine)->set_geometry({&turned, 1});
      const absl::StatusOr<PassReport> pass = (*engine)->render(1);
      if (!rebuilt.ok() || !pass.ok()) return;
      refitted += std::ranges::count(rebuilt->rebuilt, "structure_refit");
      build_ms.push_back(rebuilt->timings.structure_build_ms);
      trace_ms.push_back(rebuilt->timings.photon_trace_ms + pass->timings.photon_trace_ms);
      map_ms.push_back(rebuilt->timings.photon_map_build_ms + pass->timings.photon_map_build_ms);
      render_ms.push_back(pass->timings.render_ms);
    });
    const std::string label =
        name + absl::StrFormat(" %zu of %zu triangles moved, %dx%d k=%d %s refit=%s",
                               mesh.indices.size() / 3, resident.triangle_count(), o.width,
                               o.height, o.k, kind_name(o.estimator),
                               kind_name(moving.settings.build.refit));
    report.line("geometry_change_to_frame", label, change.median, "ms", &change, o.runs);
    for (auto* times : {&build_ms, &trace_ms, &map_ms, &render_ms})
      times->erase(times->begin(), times->begin() + std::min<size_t>(o.warmup, times->size()));
    if (build_ms.empty()) return absl::InternalError("the geometry change or its pass failed");
    report.line("geometry_change_upload_and_build", label, summarize(build_ms).median, "ms");
    report.line("geometry_change_photon_trace", label, summarize(trace_ms).median, "ms");
    report.line("geometry_change_photon_map_build", label, summarize(map_ms).median, "ms");
    report.line("geometry_change_render", label, summarize(render_ms).median, "ms");
    // The share of changes, warm-up included, that refitted the structure rather than built it.
    report.line("geometry_change_refitted", label,
                double(refitted) / double(std::max<size_t>(step, 1)), "share");
  }
  if (wanted(o, "path_pass")) {
    // One pass of the path integrator (settings.integrator "path"): a path a pixel.
    Camera camera = scene->camera;
    camera.width = o.width;
    camera.height = o.height;
    Film film(*backend, o.width, o.height);
    uint32_t pass = 0;
    try {
      Measurement m = measure(o, *backend, [&] {
        render_path_pass(*backend, resident, PinholeCamera::from(camera),
                         {scene->settings.seed, pass++}, film);
      });
      const std::string label = name + absl::StrFormat(" %dx%d", o.width, o.height);
      report.line("path_pass", label, m.median, "ms", &m, o.runs);
      report.line("path_rate", label, double(o.width) * o.height / (m.median * 1e3), "Mpaths/s");
    } catch (const std::invalid_argument& e) {
      // A structure that answers batches only (dacrt): the other benchmarks go on.
      std::cerr << "caustica-bench: path_pass skipped: " << e.what() << "\n";
    }
  }
  if (wanted(o, "photon_gather")) {
    scene->camera.width = o.width;
    scene->camera.height = o.height;
    scene->settings.k_nearest = o.k;
    scene->settings.photons_per_pass = o.photons;
    if (absl::Status s =
            photon_gather_benchmarks(o, *scene, *made, resident, per_leaf, name, report);
        !s.ok())
      return s;
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status print_ray_camera(const BenchOptions& o, std::ostream& out) {
  absl::StatusOr<Scene> scene = load_bench_mesh_scene(o);
  if (!scene.ok()) return scene.status();
  Aabb bounds;
  for (const Mesh& m : scene->meshes)
    for (Vec3f p : m.positions) bounds.extend(p);
  Camera c = framing_camera(bounds, o.width, o.height);
  out << absl::StrFormat("%.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", c.position.x,
                         c.position.y, c.position.z, c.look_at.x, c.look_at.y, c.look_at.z, c.up.x,
                         c.up.y, c.up.z, c.vertical_fov_deg);
  return absl::OkStatus();
}

absl::StatusOr<Scene> load_photon_scene(const BenchOptions& o) {
  absl::StatusOr<Scene> scene = load_scene(o.photon_scene.string());
  if (!scene.ok()) return scene.status();
  scene->camera.width = o.width;
  scene->camera.height = o.height;
  scene->settings.photons_per_pass = o.photons;
  scene->settings.k_nearest = o.k;
  scene->settings.build = apply_structure_options(o.structure_options, scene->settings.build);
  return scene;
}

std::string photon_scene_label(const BenchOptions& o) {
  return o.photon_scene.parent_path().filename().string() +
         absl::StrFormat(" %dx%d %d photons k=%d", o.width, o.height, o.photons, o.k);
}

std::vector<Light> moved_lights(const Scene& scene, int i) {
  std::vector<Light> lights = scene.lights;
  for (Light& light : lights) light.position.x += (i % 2 == 0) ? 10.0f : -10.0f;
  return lights;
}

EnvironmentChange turned_environment(const Scene& scene, int i) {
  if (!scene.environment.present) return {};
  return {std::nullopt, scene.environment.rotation_deg + ((i % 2 == 0) ? 10.0f : -10.0f)};
}

void apply_final_gather_options(const BenchOptions& o, RenderSettings& settings) {
  if (o.final_gather_rays != 0) settings.final_gather_rays = o.final_gather_rays;
  if (o.final_gather_seeds != 0) settings.final_gather_seeds = o.final_gather_seeds;
}

std::vector<std::string> benchmark_names() {
  std::vector<std::string> names = {
      "lbvh_build", "primary_rays",    "shadow_rays",   "incoherent_rays", "photon_pass",
      "frame",      "geometry_change", "photon_gather", "path_pass",       "convergence"};
  for (std::string& name : serving_benchmark_names()) names.push_back(std::move(name));
  for (std::string& name : multi_device_benchmark_names()) names.push_back(std::move(name));
  names.push_back("seed_tables");
  return names;
}

absl::Status run_benchmarks(const BenchOptions& o, std::ostream& out) {
  const std::vector<std::string> known = benchmark_names();
  for (const std::string& n : o.only)
    if (std::find(known.begin(), known.end(), n) == known.end())
      return absl::InvalidArgumentError(absl::StrCat("--only: unknown benchmark '", n, "'"));
  absl::StatusOr<std::shared_ptr<Backend>> probe = make_bench_backend(o);
  if (!probe.ok()) return probe.status();
  const DeviceInfo info = (*probe)->info();
  probe->reset();
  Reporter report(out, absl::StrFormat("%s x%d", info.name, info.compute_units));
  auto any_of = [&](const std::vector<std::string>& names) {
    return std::any_of(names.begin(), names.end(),
                       [&](const std::string& n) { return wanted(o, n); });
  };
  const bool seed_tables_named =
      std::find(o.only.begin(), o.only.end(), "seed_tables") != o.only.end();
  if (o.mesh.empty() && o.photon_scene.empty() && !seed_tables_named &&
      !any_of({"stream_rgba8", "stream_rgba32f"}))
    return absl::InvalidArgumentError("nothing to measure: give --mesh and/or --scene");
  if (!o.mesh.empty() && any_of({"lbvh_build", "primary_rays", "shadow_rays", "incoherent_rays"})) {
    if (absl::Status s = mesh_benchmarks(o, report); !s.ok()) return s;
  }
  if (!o.photon_scene.empty() &&
      any_of({"photon_pass", "frame", "geometry_change", "photon_gather", "path_pass"})) {
    for (StructureKind kind : o.structures) {
      Reporter with_structure = report.for_structure(structure_kind_name(kind));
      if (absl::Status s = photon_benchmarks(o, kind, with_structure); !s.ok()) return s;
    }
  }
  if (any_of(serving_benchmark_names())) {
    if (absl::Status s = run_serving_benchmarks(o, report); !s.ok()) return s;
  }
  // Whole animations on several engines: run only when named.
  if (std::any_of(o.only.begin(), o.only.end(), [](const std::string& n) {
        const std::vector<std::string> names = multi_device_benchmark_names();
        return std::find(names.begin(), names.end(), n) != names.end();
      })) {
    if (absl::Status s = multi_device_benchmarks(o, report); !s.ok()) return s;
  }
  // Thousands of passes: run only when named.
  if (std::find(o.only.begin(), o.only.end(), "convergence") != o.only.end()) {
    if (o.photon_scene.empty()) return absl::InvalidArgumentError("convergence needs --scene");
    if (absl::Status s = convergence_benchmark(o, report); !s.ok()) return s;
  }
  // The seeds' tables on their own scenes: run only when named.
  if (seed_tables_named) {
    if (absl::Status s = seed_tables(o, report); !s.ok()) return s;
  }

  return absl::OkStatus();
}

}  // namespace caustica
