#include "bench/multi_device.h"

#include <algorithm>
#include <memory>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "renderer/engine.h"

namespace caustica {
namespace {

constexpr int kKeyframes = 48;

// The devices --devices names: every GPU by default, and where there is one, two backends on it,
// so that the multi-device path is measured against the single one on the same chip.
absl::StatusOr<std::vector<int>> device_list(const BenchOptions& o, DeviceKind kind) {
  if (!o.devices.empty()) return o.devices;
  const int count = device_count(kind);
  if (count >= 2) {
    std::vector<int> all;
    for (int i = 0; i < count; ++i) all.push_back(i);
    return all;
  }
  return std::vector<int>{0, 0};
}

absl::StatusOr<std::unique_ptr<Engine>> engine_on(const BenchOptions& o, DeviceKind kind,
                                                  const std::vector<int>& ordinals,
                                                  const Scene& scene) {
  EngineOptions options;
  options.photons_per_leaf = o.photons_per_leaf;
  for (int ordinal : ordinals) {
    absl::StatusOr<std::shared_ptr<Backend>> backend =
        make_backend(kind, size_t(16) << 30, ordinal);
    if (!backend.ok()) return backend.status();
    options.backends.push_back(*std::move(backend));
  }
  absl::StatusOr<std::unique_ptr<Engine>> engine = Engine::create(options);
  if (!engine.ok()) return engine.status();
  if (absl::StatusOr<RebuildReport> loaded = (*engine)->load(scene); !loaded.ok())
    return loaded.status();
  return engine;
}

// Where a frame's time went: the medians of the engine's stages over the measured frames.
struct StageMedians {
  double trace = 0, maps = 0, render = 0;
};

// Frames a second of `engine`: a pass with fresh photons (trace, maps, gathers), as a frame.
Measurement frame(const BenchOptions& o, Engine& engine, StageMedians& stages) {
  std::vector<double> trace, maps, render;
  // Host clock around calls that return once every device is done: CUDA events time one stream.
  Measurement m = measure(o, [&] {
    absl::StatusOr<PassReport> report = engine.render(1);
    if (!report.ok()) return;
    trace.push_back(report->timings.photon_trace_ms);
    maps.push_back(report->timings.photon_map_build_ms);
    render.push_back(report->timings.render_ms);
  });
  // The warm-up frames come first; the medians are of the measured ones.
  auto measured = [&](std::vector<double>& v) {
    v.erase(v.begin(), v.begin() + std::min<size_t>(v.size(), size_t(o.warmup)));
    return v.empty() ? 0.0 : summarize(v).median;
  };
  stages = {measured(trace), measured(maps), measured(render)};
  return m;
}

// One run of the animation: each keyframe a light change (photons and maps), a pass and the
// image resolved into host memory, as the server serves a keyframe before encoding it.
Measurement animation(const BenchOptions& o, Engine& engine, const Scene& scene) {
  return measure(o, [&] {
    for (int i = 0; i < kKeyframes; ++i) {
      (void)engine.set_lights(moved_lights(scene, i));
      (void)engine.render(1);
      (void)engine.image_srgb8();
    }
  });
}

}  // namespace

std::vector<std::string> multi_device_benchmark_names() {
  return {"frame_devices", "animation_devices"};
}

absl::Status multi_device_benchmarks(const BenchOptions& o, Reporter& report) {
  if (o.photon_scene.empty()) {
    return absl::InvalidArgumentError("frame_devices and animation_devices need --scene");
  }
  absl::StatusOr<DeviceKind> kind = parse_device_kind(o.device);
  if (!kind.ok()) return kind.status();
  absl::StatusOr<std::vector<int>> devices = device_list(o, *kind);
  if (!devices.ok()) return devices.status();
  absl::StatusOr<Scene> scene = load_photon_scene(o);
  if (!scene.ok()) return scene.status();
  scene->settings.estimator = o.estimator;

  const std::string name = photon_scene_label(o);
  const std::vector<std::vector<int>> setups = {{devices->front()}, *devices};
  std::vector<double> frames_per_s[2];
  for (size_t s = 0; s < setups.size(); ++s) {
    absl::StatusOr<std::unique_ptr<Engine>> engine = engine_on(o, *kind, setups[s], *scene);
    if (!engine.ok()) return engine.status();
    const std::string on =
        absl::StrFormat("%s, %zu device%s [%s]", name, setups[s].size(),
                        setups[s].size() == 1 ? "" : "s", absl::StrJoin(setups[s], ","));
    if (wanted(o, "frame_devices")) {
      StageMedians stages;
      const Measurement m = frame(o, **engine, stages);
      report.line("frame_devices", on, 1000.0 / m.median, "frames/s", &m, o.runs);
      // Tracing is split over the devices, the maps are built on each from all the photons
      // (merge included), and the gathers are split by rows.
      report.point("frame_devices_stages", on,
                   absl::StrFormat(R"("photon_trace_ms": %.4g, "photon_maps_ms": %.4g, )"
                                   R"("render_ms": %.4g, "frame_ms": %.4g)",
                                   stages.trace, stages.maps, stages.render, m.median));
      frames_per_s[0].push_back(1000.0 / m.median);
    }
    if (wanted(o, "animation_devices")) {
      const Measurement m = animation(o, **engine, *scene);
      report.line("animation_devices",
                  absl::StrCat(on, absl::StrFormat(", %d keyframes", kKeyframes)),
                  kKeyframes * 1000.0 / m.median, "frames/s", &m, o.runs);
      frames_per_s[1].push_back(kKeyframes * 1000.0 / m.median);
    }
  }
  const char* names[2] = {"frame_devices_speedup", "animation_devices_speedup"};
  for (int b = 0; b < 2; ++b) {
    if (frames_per_s[b].size() != 2) continue;
    report.line(names[b],
                absl::StrFormat("%s, %zu devices [%s] against 1", name, devices->size(),
                                absl::StrJoin(*devices, ",")),
                frames_per_s[b][1] / frames_per_s[b][0], "x");
  }
  return absl::OkStatus();
}

}  // namespace caustica
