#include "server/metrics.h"

#include <prometheus/collectable.h>
#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>

#include <exception>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/http/http_server.h"

namespace caustica::server {
namespace {

// Upper bounds in seconds: from a cached light change (about a millisecond on a GPU) to a long
// stream or animation.
prometheus::Histogram::BucketBoundaries latency_buckets() {
  return {0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60};
}

prometheus::MetricFamily gauge(const std::string& name, const std::string& help, double value) {
  prometheus::MetricFamily family{name, help, prometheus::MetricType::Gauge, {}};
  prometheus::ClientMetric metric;
  metric.gauge.value = value;
  family.metric.push_back(metric);
  return family;
}

// One gauge per device, labelled device="<index>".
prometheus::MetricFamily device_gauge(const std::string& name, const std::string& help,
                                      const std::vector<DeviceReadings>& devices,
                                      size_t DeviceReadings::*field) {
  prometheus::MetricFamily family{name, help, prometheus::MetricType::Gauge, {}};
  for (size_t i = 0; i < devices.size(); ++i) {
    prometheus::ClientMetric metric;
    metric.label.push_back({"device", std::to_string(i)});
    metric.gauge.value = double(devices[i].*field);
    family.metric.push_back(std::move(metric));
  }
  return family;
}

}  // namespace

// The gauges, read from the server at each scrape rather than kept up to date by every call.
class ServerMetrics::Gauges final : public prometheus::Collectable {
 public:
  explicit Gauges(std::function<ServerReadings()> read) : read_(std::move(read)) {}

  std::vector<prometheus::MetricFamily> Collect() const override {
    const ServerReadings r = read_();
    return {
        gauge("caustica_memory_used_bytes", "Device memory the scenes hold now, all devices.",
              double(r.memory_used_bytes)),
        gauge("caustica_memory_peak_bytes",
              "The most device memory held since the start, summed over the devices.",
              double(r.memory_peak_bytes)),
        gauge("caustica_memory_budget_bytes", "Device memory all scenes may hold together.",
              double(r.memory_budget_bytes)),
        device_gauge("caustica_device_memory_used_bytes",
                     "Memory the scenes hold now on one device.", r.devices,
                     &DeviceReadings::memory_used_bytes),
        device_gauge("caustica_device_memory_budget_bytes",
                     "Memory the scenes may hold on one device (--memory-budget).", r.devices,
                     &DeviceReadings::memory_budget_bytes),
        device_gauge("caustica_device_queue_waiting", "Calls waiting for one device now.",
                     r.devices, &DeviceReadings::queue_waiting),
        gauge("caustica_scenes", "Resident scenes.", double(r.scenes)),
        gauge("caustica_max_scenes", "The most resident scenes (--max-scenes).",
              double(r.max_scenes)),
        gauge("caustica_active_streams", "Frame streams and animations running.",
              double(r.active_streams)),
        gauge("caustica_calls_in_flight", "Calls being handled.", double(r.calls_in_flight)),
    };
  }

 private:
  std::function<ServerReadings()> read_;
};

ServerMetrics::ServerMetrics(std::function<ServerReadings()> read)
    : registry_(std::make_shared<prometheus::Registry>()),
      gauges_(std::make_shared<Gauges>(std::move(read))) {
  calls_ = &prometheus::BuildCounter()
                .Name("caustica_requests_total")
                .Help("Calls finished, by method and status code.")
                .Register(*registry_);
  call_seconds_ = &prometheus::BuildHistogram()
                       .Name("caustica_request_duration_seconds")
                       .Help("Time from a call's start to its status, by method.")
                       .Register(*registry_);
  stage_seconds_ = &prometheus::BuildHistogram()
                        .Name("caustica_stage_duration_seconds")
                        .Help(
                            "Time of one run of a pipeline stage: structure_build, "
                            "photon_trace, photon_map_build, render, resolve, or queue (the "
                            "wait for the device).")
                        .Register(*registry_);
}

ServerMetrics::~ServerMetrics() = default;

absl::StatusOr<int> ServerMetrics::serve(const std::string& listen) {
  http::HttpRoutes routes;
  routes.serve = [this](const http::HttpRequest& request) -> http::HttpResponse {
    if (request.path != "/metrics") return http::plain_text_response(404, "see /metrics");
    if (request.method != "GET" && request.method != "HEAD") {
      return http::plain_text_response(405, "only GET and HEAD");
    }
    http::HttpResponse response;
    response.content_type = "text/plain; version=0.0.4; charset=utf-8";
    response.body = text();
    return response;
  };
  http::HttpLimits limits;
  limits.max_websockets = 0;
  limits.io_threads = 1;
  absl::StatusOr<std::unique_ptr<http::HttpServer>> server =
      http::HttpServer::start(listen, "--metrics-listen", std::move(routes), limits);
  if (!server.ok()) return server.status();
  http_ = *std::move(server);
  return http_->port();
}

void ServerMetrics::record_call(std::string_view method, absl::StatusCode code, double ms) {
  const std::string name(method);
  calls_->Add({{"method", name}, {"code", absl::StatusCodeToString(code)}}).Increment();
  call_seconds_->Add({{"method", name}}, latency_buckets()).Observe(ms / 1000.0);
}

void ServerMetrics::record_stage(std::string_view stage, double ms) {
  stage_seconds_->Add({{"stage", std::string(stage)}}, latency_buckets()).Observe(ms / 1000.0);
}

std::string ServerMetrics::text() const {
  std::vector<prometheus::MetricFamily> families = registry_->Collect();
  for (prometheus::MetricFamily& f : gauges_->Collect()) families.push_back(std::move(f));
  return prometheus::TextSerializer().Serialize(families);
}

}  // namespace caustica::server
