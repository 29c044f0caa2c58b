#include "tools/render/render_job.h"

#include <chrono>
#include <cstdio>
#include <iostream>

#include "absl/strings/str_format.h"
#include "imageio/image_io.h"
#include "renderer/scene/load_scene.h"

namespace caustica {

absl::StatusOr<RenderSummary> run_render_job(const RenderJob& job, std::ostream& log) {
  RenderSummary summary;
  auto t0 = std::chrono::steady_clock::now();
  std::vector<std::string> warnings;
  absl::StatusOr<Scene> scene = load_scene(job.scene, &warnings);
  if (!scene.ok()) return scene.status();
  for (const std::string& warning : warnings) log << "warning: " << warning << "\n";
  summary.load_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  Camera& cam = scene->camera;
  RenderSettings& rs = scene->settings;
  if (job.width) cam.width = *job.width;
  if (job.height) cam.height = *job.height;
  if (job.photons) rs.photons_per_pass = *job.photons;
  if (job.k) rs.k_nearest = *job.k;
  if (job.passes) rs.passes = *job.passes;
  if (job.seed) rs.seed = *job.seed;
  if (job.structure) rs.structure = *job.structure;
  rs.build = apply_structure_options(job.structure_options, rs.build);
  if (job.integrator) rs.integrator = *job.integrator;
  if (job.estimator) rs.estimator = *job.estimator;
  if (job.final_gather) rs.final_gather = *job.final_gather;

  absl::StatusOr<std::unique_ptr<Engine>> engine = Engine::create({});
  if (!engine.ok()) return engine.status();
  if (auto loaded = (*engine)->load(*scene); !loaded.ok()) return loaded.status();
  summary.stats = (*engine)->scene_stats();

  auto progress = [&](uint32_t done, uint32_t total) {
    if (job.show_progress) std::fprintf(stderr, "\rrendering: pass %u/%u", done, total);
  };
  absl::StatusOr<PassReport> report = (*engine)->render(rs.passes, progress);
  if (job.show_progress) std::fprintf(stderr, "\n");
  if (!report.ok()) return report.status();
  summary.report = *report;

  const std::span<const float> pixels = (*engine)->image_linear();
  LinearImage image{cam.width, cam.height, {pixels.begin(), pixels.end()}};
  if (absl::Status s = write_image(job.output, image, job.exposure_stops); !s.ok()) return s;

  const StageTimings& t = report->timings;
  const DeviceInfo device = (*engine)->device_info();
  log << absl::StrFormat("scene        %s: %d triangles, %d lights (loaded in %.1f ms)\n",
                         job.scene.string(), summary.stats.triangles, summary.stats.lights,
                         summary.load_ms);
  log << absl::StrFormat("device       %s, %d threads\n", device.name, device.compute_units);
  log << absl::StrFormat("structure    %s, %d nodes, %.1f MiB, SAH %.1f, built in %.2f ms\n",
                         structure_kind_name(summary.stats.structure),
                         summary.stats.structure_nodes, summary.stats.structure_bytes / 1048576.0,
                         summary.stats.structure_sah_cost, summary.stats.last_structure_build_ms);
  if (rs.integrator == Integrator::kPath) {
    log << absl::StrFormat("integrator   path: one path a pixel a pass, no photons\n");
    log << absl::StrFormat("passes       %d at %dx%d\n", report->passes_rendered, cam.width,
                           cam.height);
  } else {
    log << absl::StrFormat(
        "estimator    %s%s\n", kind_name(rs.estimator),
        rs.final_gather
            ? absl::StrFormat(", final gathering with %d rays a seed", rs.final_gather_rays)
            : "");
    log << absl::StrFormat(
        "photons      %d emitted per pass; last pass stored %d caustic, %d global\n",
        rs.photons_per_pass, report->caustic_photons, report->global_photons);
    log << absl::StrFormat("passes       %d at %dx%d, k = %d, max radius %.4g\n",
                           report->passes_rendered, cam.width, cam.height, rs.k_nearest,
                           (*engine)->shading(0).max_radius);
  }
  log << absl::StrFormat(
      "time (ms)    photon trace %.1f | photon maps %.1f | render %.1f | total %.1f\n",
      t.photon_trace_ms, t.photon_map_build_ms, t.render_ms, t.total());
  log << absl::StrFormat("wrote        %s\n", job.output.string());
  return summary;
}

}  // namespace caustica
