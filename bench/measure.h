// Timing and reporting shared by the benchmarks: warm-up runs, then the median (with min and
// max) of measured runs, printed as one JSON line per figure; with --kernels, also one line per
// launch name of the measured runs.
#pragma once

#include <algorithm>
#include <chrono>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "bench/benchmarks.h"
#include "renderer/parallel/backend.h"

namespace caustica {

struct Measurement {
  double median, min, max;
  // With --kernels: the launches of all the measured runs, summed per name, the most time first.
  std::vector<LaunchTime> kernels;
};

// Whether --only selects the benchmark `name` (everything when --only is empty).
inline bool wanted(const BenchOptions& o, const std::string& name) {
  return o.only.empty() || std::find(o.only.begin(), o.only.end(), name) != o.only.end();
}

inline Measurement summarize(std::vector<double> ms) {
  std::sort(ms.begin(), ms.end());
  return {ms[ms.size() / 2], ms.front(), ms.back(), {}};
}

// Milliseconds of host-side work `fn` (a round trip to a server) over o.runs runs after
// o.warmup unmeasured ones.
inline Measurement measure(const BenchOptions& o, const std::function<void()>& fn) {
  for (int i = 0; i < o.warmup; ++i) fn();
  std::vector<double> ms;
  for (int i = 0; i < o.runs; ++i) {
    auto start = std::chrono::steady_clock::now();
    fn();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                     .count());
  }
  return summarize(std::move(ms));
}

// Device work is timed by the backend: CUDA events on the GPU, the host clock around
// synchronisations on the CPU. With --kernels the measured runs (not the warm-ups) are also timed
// per launch, so their figures include what that timing costs.
inline Measurement measure(const BenchOptions& o, Backend& backend,
                           const std::function<void()>& fn) {
  for (int i = 0; i < o.warmup; ++i) fn();
  if (o.kernels) {
    backend.clear_launch_times();
    backend.set_launch_timing(true);
  }
  std::vector<double> ms;
  for (int i = 0; i < o.runs; ++i) ms.push_back(backend.time_ms(fn));
  Measurement m = summarize(std::move(ms));
  if (o.kernels) {
    backend.set_launch_timing(false);
    m.kernels = backend.launch_times();
    backend.clear_launch_times();
  }
  return m;
}

class Reporter {
 public:
  Reporter(std::ostream& out, std::string device) : out_(out), device_(std::move(device)) {}
  // The same output, labelled with another device (the server's, for the serving figures).
  Reporter for_device(std::string device) const {
    Reporter r(out_, std::move(device));
    r.structure_ = structure_;
    return r;
  }
  // The same output, each line naming the triangle structure it measured.
  Reporter for_structure(std::string structure) const {
    Reporter r(out_, device_);
    r.structure_ = std::move(structure);
    return r;
  }
  void line(const std::string& name, const std::string& scene, double value,
            const std::string& unit, const Measurement* m = nullptr, int runs = 0) {
    out_ << absl::StrFormat(
        R"({"name": "%s", "scene": "%s", "device": "%s", "value": %.6g, "unit": "%s")", name, scene,
        device_, value, unit);
    if (!structure_.empty()) out_ << absl::StrFormat(R"(, "structure": "%s")", structure_);
    if (m != nullptr)
      out_ << absl::StrFormat(R"(, "median_ms": %.6g, "min_ms": %.6g, "max_ms": %.6g, "runs": %d)",
                              m->median, m->min, m->max, runs);
    out_ << "}\n";
    if (m != nullptr && runs > 0) kernels(name, scene, *m, runs);
    out_.flush();
  }
  // A line of fields of its own (`fields`: JSON members, comma-separated, without braces).
  void point(const std::string& name, const std::string& scene, const std::string& fields) {
    out_ << absl::StrFormat(R"({"name": "%s", "scene": "%s", "device": "%s", )", name, scene,
                            device_)
         << fields << "}\n";
    out_.flush();
  }
  // One line per launch name of `m`'s measured runs (--kernels), the most time first, under the
  // benchmark line `benchmark` that the measurement gave.
  void kernels(const std::string& benchmark, const std::string& scene, const Measurement& m,
               int runs) {
    for (const LaunchTime& k : m.kernels) {
      out_ << absl::StrFormat(
          R"({"name": "kernel", "benchmark": "%s", "scene": "%s", "device": "%s", "kernel": "%s", )"
          R"("launches_per_run": %.6g, "ms_per_run": %.6g)",
          benchmark, scene, device_, k.name, double(k.launches) / runs, k.total_ms / runs);
      if (!structure_.empty()) out_ << absl::StrFormat(R"(, "structure": "%s")", structure_);
      out_ << "}\n";
    }
  }

 private:
  std::ostream& out_;
  std::string device_;
  std::string structure_;
};

}  // namespace caustica
