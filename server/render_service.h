// caustica.v1.RenderService over the sync gRPC API. Every call runs through one wrapper that logs
// a line with its latency and status, records the latency for GetStats and turns the absl::Status
// of the work into a grpc::Status with the same code and message. Each device has a DeviceQueue
// and each scene lives on a set of devices (one, or all with --split-frames); engine work holds
// the queues of its scene's devices one pass (or one rebuild) at a time, so concurrent clients
// share a device fairly, scenes on different devices render at once, and cancellation, deadlines
// and shutdown take effect between passes.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.grpc.pb.h"
#include "renderer/engine.h"
#include "server/device_queue.h"
#include "server/frame_encoding.h"
#include "server/latency_stats.h"
#include "server/metrics.h"
#include "server/scene_registry.h"
#include "server/scene_store.h"

namespace caustica::server {

// For tests: milliseconds to pause before restoring each stored scene, so that a test can watch
// the server while it restores.
inline constexpr char kRestoreDelayVariable[] = "CAUSTICA_RESTORE_DELAY_MS";

struct ServiceOptions {
  size_t max_scenes = 16;
  size_t max_message_bytes = size_t{64} << 20;
  // --data-dir: every acknowledged upload, update and delete is stored first. Null: scenes live
  // only in the process.
  std::shared_ptr<SceneStore> store;
  // Per tenant (0: no limit beyond the server's): scenes, uploads included; the share of the
  // memory budget its scenes may hold, in (0, 1]; frame streams open at once.
  size_t max_tenant_scenes = 0;
  double tenant_memory_share = 1.0;
  size_t max_tenant_streams = 0;
  // A scene no call has touched for this long is deleted, as if its tenant had deleted it.
  // 0: never.
  double scene_idle_ttl_s = 0;
  // --split-frames: every scene on every device, so one frame uses them all. Otherwise each scene
  // goes to the device with the most free budget when it is uploaded or restored.
  bool split_frames = false;
};

class RenderService final : public v1::RenderService::Service {
 public:
  // One device per backend, at least one; their order gives the indices that GetStats and
  // SceneInfo.devices report.
  RenderService(std::vector<std::shared_ptr<Backend>> backends, const ServiceOptions& options);
  ~RenderService() override;

  // New calls and running streams end with UNAVAILABLE; waiters for the devices give up.
  void begin_shutdown();
  // Rebuilds every scene of the store, with its id, state and epochs. Until it returns, calls
  // other than GetVersion and GetStats are UNAVAILABLE. A scene that cannot be restored (its blob
  // damaged, or beyond the memory budget) is logged and left in the store. Returns how many were
  // restored.
  size_t restore_scenes();
  bool restoring() const { return restoring_; }
  // Handlers running now.
  uint32_t calls_in_flight() const { return calls_in_flight_; }
  // The browser viewer's bound port, which GetStats reports (0: none).
  void set_viewer_port(int port) { viewer_port_ = port; }
  // What the calls and stages recorded, for /metrics.
  ServerMetrics& metrics() { return metrics_; }

  grpc::Status UploadScene(grpc::ServerContext* context, grpc::ServerReader<v1::SceneChunk>* reader,
                           v1::SceneInfo* response) override;
  grpc::Status ListScenes(grpc::ServerContext* context, const v1::ListScenesRequest* request,
                          v1::ListScenesResponse* response) override;
  grpc::Status GetScene(grpc::ServerContext* context, const v1::GetSceneRequest* request,
                        v1::SceneInfo* response) override;
  grpc::Status DeleteScene(grpc::ServerContext* context, const v1::DeleteSceneRequest* request,
                           v1::DeleteSceneResponse* response) override;
  grpc::Status UpdateLights(grpc::ServerContext* context, const v1::UpdateLightsRequest* request,
                            v1::RebuildReport* response) override;
  grpc::Status UpdateCamera(grpc::ServerContext* context, const v1::UpdateCameraRequest* request,
                            v1::RebuildReport* response) override;
  grpc::Status UpdateGeometry(grpc::ServerContext* context,
                              const v1::UpdateGeometryRequest* request,
                              v1::RebuildReport* response) override;
  grpc::Status StreamGeometry(grpc::ServerContext* context,
                              grpc::ServerReader<v1::GeometryChunk>* reader,
                              v1::RebuildReport* response) override;
  grpc::Status UpdateSettings(grpc::ServerContext* context,
                              const v1::UpdateSettingsRequest* request,
                              v1::RebuildReport* response) override;
  grpc::Status RenderFrame(grpc::ServerContext* context, const v1::RenderFrameRequest* request,
                           v1::Frame* response) override;
  grpc::Status StreamFrames(grpc::ServerContext* context, const v1::StreamFramesRequest* request,
                            grpc::ServerWriter<v1::Frame>* writer) override;
  grpc::Status PlayAnimation(grpc::ServerContext* context, const v1::PlayAnimationRequest* request,
                             grpc::ServerWriter<v1::Frame>* writer) override;
  grpc::Status GetStats(grpc::ServerContext* context, const v1::GetStatsRequest* request,
                        v1::Stats* response) override;
  grpc::Status GetVersion(grpc::ServerContext* context, const v1::GetVersionRequest* request,
                          v1::VersionInfo* response) override;

 private:
  // A frame resolved from the film: header fields and the encoded bytes.
  struct EncodedFrame {
    v1::Frame header;
    std::string data;
  };

  class StreamSlot;

  // One device: its backend, which the engines of every scene there share, and the queue that
  // serialises their work on it.
  struct Device {
    std::shared_ptr<Backend> backend;
    DeviceInfo info;
    DeviceQueue queue;
    // Declared bytes of uploads placed here whose scenes are not built yet, so that concurrent
    // uploads see each other and spread over the devices. Guarded by placement_mutex_.
    size_t reserved_bytes = 0;
  };

  // The leases of a scene's devices, taken in ascending index order (so two calls never wait for
  // each other's devices) and released together.
  class Leases {
   public:
    double waited_ms() const { return waited_ms_; }
    void release() {
      for (DeviceQueue::Lease& lease : held_) lease.release();
    }

   private:
    friend class RenderService;
    std::vector<DeviceQueue::Lease> held_;
    double waited_ms_ = 0;
  };
  // A frame call's scene and checked format, and for a stream its place among the tenant's.
  struct FrameCall {
    std::shared_ptr<SceneEntry> entry;
    FrameSpec spec;
    std::unique_ptr<StreamSlot> stream;
  };

  // Authenticates (auth.h), logs, records and converts; `work` gets the caller's tenant.
  // `scene_id` is read after `work` ran (uploads learn it late).
  grpc::Status serve(grpc::ServerContext* context, const char* method, const std::string& scene_id,
                     const std::function<absl::Status(const std::string& tenant)>& work);
  // serve() for the update calls: finds the scene, runs `change` through rebuild() and answers
  // with its report.
  grpc::Status serve_update(grpc::ServerContext* context, const char* method,
                            const std::string& scene_id, v1::RebuildReport* response,
                            const std::function<absl::StatusOr<RebuildReport>(Engine&)>& change);
  // NOT_FOUND / INVALID_ARGUMENT, and for a `stream` RESOURCE_EXHAUSTED beyond
  // --tenant-max-streams, before any frame work starts.
  absl::StatusOr<FrameCall> start_frames(const std::string& tenant, const std::string& scene_id,
                                         const v1::FrameFormat& format, bool stream);
  // RESOURCE_EXHAUSTED, naming the scene and --tenant-memory-share, when what a geometry change
  // of `engine` builds beside the scene would take the tenant's scenes past its share; the
  // device's budget is the backend's to enforce, which refuses the change changing nothing.
  absl::Status check_geometry_room(const std::string& tenant, const SceneEntry& entry,
                                   const Engine& engine) const;
  // UpdateGeometry's change (StreamGeometry's once its chunks are put together): the epoch it
  // expects and the tenant's room checked under the lease, then Engine::set_geometry.
  absl::StatusOr<v1::RebuildReport> change_geometry(grpc::ServerContext* context,
                                                    const std::string& tenant,
                                                    const v1::UpdateGeometryRequest& request);
  // Removes a scene from the store and the registry and frees its device memory; the bytes freed.
  absl::StatusOr<size_t> forget(SceneEntry& entry);
  // The device memory a tenant's scenes hold, and the most they may.
  size_t tenant_bytes(const std::string& tenant) const;
  size_t tenant_memory_limit() const;
  // RESOURCE_EXHAUSTED, led by `what`, when `bytes` more would take the tenant past its
  // --tenant-memory-share.
  absl::Status check_tenant_share(const std::string& tenant, size_t bytes,
                                  const std::string& what) const;
  // One open frame stream of `tenant` while it lives; RESOURCE_EXHAUSTED beyond
  // --tenant-max-streams.
  absl::StatusOr<std::unique_ptr<StreamSlot>> open_stream(const std::string& tenant);
  uint32_t tenant_streams(const std::string& tenant) const;
  // Deletes scenes idle beyond --scene-idle-ttl until shutdown.
  void reap_idle_scenes();
  absl::Status restore_scene(const StoredScene& stored);
  // Stores the engine's state after a change, before the change is acknowledged.
  absl::Status persist(const SceneEntry& entry);
  // CANCELLED, DEADLINE_EXCEEDED or UNAVAILABLE when the call should stop now.
  absl::Status stop_status(grpc::ServerContext* context) const;
  // Waits for every device of `devices` (ascending), giving up like DeviceQueue::acquire.
  absl::StatusOr<Leases> acquire_devices(const std::vector<uint32_t>& devices,
                                         const DeviceQueue::StopCheck& stop);
  // Waits for the scene's devices; NOT_FOUND when the scene was deleted meanwhile. Adds the wait
  // to `queue_ms` when given.
  absl::StatusOr<Leases> acquire(grpc::ServerContext* context, const SceneEntry& entry,
                                 double* queue_ms);
  // The devices for a new scene of `bytes` declared bytes, reserved there until unreserve():
  // every device with --split-frames, else the one with the most free budget (the lowest index
  // of equals). RESOURCE_EXHAUSTED, led by `what`, when the bytes do not fit there.
  absl::StatusOr<std::vector<uint32_t>> place(size_t bytes, const std::string& what);
  void unreserve(const std::vector<uint32_t>& devices, size_t bytes);
  // A new engine on `devices`.
  absl::StatusOr<std::unique_ptr<Engine>> create_engine(const std::vector<uint32_t>& devices) const;
  // Summed over every device: memory in use, peak and budget.
  // One of the backends' byte counts summed over the devices.
  size_t sum_over_devices(size_t (Backend::*bytes)() const) const;
  size_t memory_used() const;
  size_t memory_peak() const;
  size_t memory_budget() const;
  // Stats.devices, and the first device and the sums in the fields that predate it.
  void describe_devices(v1::Stats* response) const;
  // Runs one engine change under the lease, records its stages, refreshes the scene's snapshot
  // and returns the report (with the queue time).
  absl::StatusOr<v1::RebuildReport> rebuild(
      grpc::ServerContext* context, SceneEntry& entry,
      const std::function<absl::StatusOr<RebuildReport>(Engine&)>& change);
  // Renders up to `max_passes` passes, one lease each, stopping once the film holds `target`
  // passes (0: the scene's settings.passes), then resolves and encodes the film.
  absl::StatusOr<EncodedFrame> produce_frame(grpc::ServerContext* context, SceneEntry& entry,
                                             uint32_t target, uint32_t max_passes,
                                             const FrameSpec& spec);
  // Writes one frame as `frame_number` in pieces of `chunk_bytes`, each built once the one before
  // was written; CANCELLED when the client stopped reading.
  absl::Status send_frame(grpc::ServerWriter<v1::Frame>* writer, EncodedFrame& frame,
                          size_t chunk_bytes, uint64_t frame_number);
  // The chunk size for a request's max_chunk_bytes (frame_chunk_bytes under the message limit).
  size_t chunk_bytes(uint32_t requested) const;
  void record_stages(const StageTimings& timings);
  // One run of `stage` ("queue", "render", ...), for GetStats' percentiles and /metrics.
  void record_stage(const char* stage, double ms);

  const ServiceOptions options_;
  // Never resized after construction: queues are not movable and handlers index it freely.
  std::vector<std::unique_ptr<Device>> devices_;
  std::mutex placement_mutex_;
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  SceneRegistry registry_;
  LatencyStats latencies_;
  std::atomic<bool> shutting_down_{false};
  std::atomic<bool> restoring_{false};
  std::atomic<size_t> restore_done_{0}, restore_total_{0};
  std::atomic<uint64_t> frames_served_{0};
  std::atomic<uint64_t> requests_served_{0};
  std::atomic<uint32_t> active_streams_{0};
  std::atomic<uint32_t> calls_in_flight_{0};
  std::atomic<int> viewer_port_{0};
  mutable std::mutex streams_mutex_;
  std::map<std::string, uint32_t, std::less<>> tenant_streams_;
  std::mutex reaper_mutex_;
  std::condition_variable reaper_wake_;
  std::thread reaper_;
  ServerMetrics metrics_;  // last: its gauges read the members above
};

}  // namespace caustica::server
