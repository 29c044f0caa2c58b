// Latency percentiles per named series (an RPC method or a pipeline stage) for GetStats. Each
// series keeps its most recent samples in a ring, so percentiles follow the server's current load
// and memory stays bounded however long it runs; count and max cover every sample.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace caustica::server {

struct LatencySummary {
  std::string name;
  uint64_t count = 0;
  double p50_ms = 0, p90_ms = 0, p99_ms = 0, max_ms = 0;
};

// Nearest-rank percentile (the smallest sample with at least p% of the samples at or below it)
// of `samples`, which it sorts. 0 for no samples.
double percentile(std::vector<double>& samples, double p);

// Thread-safe.
class LatencyStats {
 public:
  explicit LatencyStats(size_t window = 4096) : window_(window) {}

  void record(std::string_view name, double ms);
  // One summary per series, ordered by name.
  std::vector<LatencySummary> summaries() const;

 private:
  struct Series {
    std::vector<double> recent;  // ring of at most window_ samples
    size_t next = 0;             // where the next sample goes once the ring is full
    uint64_t count = 0;
    double max_ms = 0;
  };
  const size_t window_;
  mutable std::mutex mutex_;
  std::map<std::string, Series, std::less<>> series_;
};

}  // namespace caustica::server
