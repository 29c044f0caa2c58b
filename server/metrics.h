// The server's Prometheus metrics (docs/server.md, "Metrics"), through prometheus-cpp: calls by
// method and status code, latency histograms per call and per pipeline stage, and gauges read at
// each scrape (memory in use, peak and budget, over all devices and per device, scenes, streams and
// calls running). Served as text on /metrics when the server is given --metrics-listen, by the
// same bounded HTTP server as the viewer (server/http).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace prometheus {
class Registry;
template <typename T>
class Family;
class Counter;
class Histogram;
}  // namespace prometheus

namespace caustica::server {
namespace http {
class HttpServer;
}

// One device's gauges, labelled with its index.
struct DeviceReadings {
  size_t memory_used_bytes = 0;
  size_t memory_budget_bytes = 0;
  size_t queue_waiting = 0;
};

// What the gauges show, read when Prometheus scrapes.
struct ServerReadings {
  size_t memory_used_bytes = 0;
  size_t memory_peak_bytes = 0;
  size_t memory_budget_bytes = 0;
  size_t scenes = 0;
  size_t max_scenes = 0;
  uint32_t active_streams = 0;
  uint32_t calls_in_flight = 0;
  std::vector<DeviceReadings> devices;  // by device index
};

class ServerMetrics {
 public:
  explicit ServerMetrics(std::function<ServerReadings()> read);
  ~ServerMetrics();

  // Serves /metrics on `listen` (host:port, port 0 for a free one); the bound port, or
  // INVALID_ARGUMENT naming the address when it cannot listen there.
  absl::StatusOr<int> serve(const std::string& listen);

  // One finished call of `method` ("UploadScene") with its status and latency.
  void record_call(std::string_view method, absl::StatusCode code, double ms);
  // One run of pipeline stage `stage` ("photon_trace", "queue", ...).
  void record_stage(std::string_view stage, double ms);

  // The exposition text, as /metrics serves it.
  std::string text() const;

 private:
  class Gauges;
  std::shared_ptr<prometheus::Registry> registry_;
  std::shared_ptr<Gauges> gauges_;
  prometheus::Family<prometheus::Counter>* calls_;
  prometheus::Family<prometheus::Histogram>* call_seconds_;
  prometheus::Family<prometheus::Histogram>* stage_seconds_;
  std::unique_ptr<http::HttpServer> http_;
};

}  // namespace caustica::server
