#include "server/latency_stats.h"

#include <algorithm>
#include <cmath>

namespace caustica::server {

double percentile(std::vector<double>& samples, double p) {
  if (samples.empty()) return 0;
  std::sort(samples.begin(), samples.end());
  const double rank = std::ceil(p / 100.0 * static_cast<double>(samples.size()));
  const size_t index = static_cast<size_t>(std::clamp(rank, 1.0, double(samples.size()))) - 1;
  return samples[index];
}

void LatencyStats::record(std::string_view name, double ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = series_.find(name);
  if (it == series_.end()) {
    it = series_.emplace(std::string(name), Series{}).first;
    // The whole window at once, so that the server's memory does not grow with its first samples
    // (which a soak would read as a leak).
    it->second.recent.reserve(window_);
  }
  Series& s = it->second;
  if (s.recent.size() < window_) {
    s.recent.push_back(ms);
  } else {
    s.recent[s.next] = ms;
    s.next = (s.next + 1) % window_;
  }
  ++s.count;
  s.max_ms = std::max(s.max_ms, ms);
}

std::vector<LatencySummary> LatencyStats::summaries() const {
  std::vector<LatencySummary> out;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [name, s] : series_) {
    std::vector<double> sorted = s.recent;
    LatencySummary summary{name, s.count};
    summary.p50_ms = percentile(sorted, 50);
    summary.p90_ms = percentile(sorted, 90);
    summary.p99_ms = percentile(sorted, 99);
    summary.max_ms = s.max_ms;
    out.push_back(std::move(summary));
  }
  return out;
}

}  // namespace caustica::server
