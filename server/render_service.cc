#include "server/render_service.h"

#include <algorithm>
#include <cstdlib>
#include <limits>
#include <optional>
#include <span>
#include <thread>
#include <utility>

#include "absl/cleanup/cleanup.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "proto/wire/api_version.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/texture_decode.h"
#include "server/auth.h"
#include "server/engine_wire.h"
#include "server/geometry_stream.h"
#include "server/heap.h"
#include "server/log.h"

namespace caustica::server {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Status messages quote what clients sent (an unknown scene id, a bad name), and travel back in a
// trailer that clients refuse past a few kilobytes; so a message is cut to this length.
constexpr size_t kMaxStatusMessageBytes = 1024;

grpc::Status to_grpc(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  std::string message(status.message());
  if (message.size() > kMaxStatusMessageBytes) {
    message = absl::StrCat(message.substr(0, kMaxStatusMessageBytes), "... (",
                           message.size(), " bytes in all)");
  }
  // absl and gRPC share the canonical code numbers.
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), message);
}

// produce_frame's max_passes when only the target bounds the passes.
constexpr uint32_t kAllPasses = std::numeric_limits<uint32_t>::max();

std::string mib(size_t bytes) { return absl::StrFormat("%.1f MiB", bytes / 1048576.0); }

// Counts a running call or stream, however it ends.
class ScopedCount {
 public:
  explicit ScopedCount(std::atomic<uint32_t>& count) : count_(count) { ++count_; }
  ~ScopedCount() { --count_; }

 private:
  std::atomic<uint32_t>& count_;
};

}  // namespace

RenderService::RenderService(std::vector<std::shared_ptr<Backend>> backends,
                             const ServiceOptions& options)
    : options_(options), registry_(options.max_scenes, options.max_tenant_scenes), metrics_([this] {
        ServerReadings readings{
            memory_used(),          memory_peak(),   memory_budget(),  registry_.size(),
            registry_.max_scenes(), active_streams_, calls_in_flight_, {}};
        for (const auto& device : devices_) {
          readings.devices.push_back({device->backend->bytes_in_use(), device->backend->budget(),
                                      device->queue.waiting()});
        }
        return readings;
      }) {
  for (std::shared_ptr<Backend>& backend : backends) {
    auto device = std::make_unique<Device>();
    device->info = backend->info();
    device->backend = std::move(backend);
    devices_.push_back(std::move(device));
  }
  restoring_ = options_.store != nullptr;
  if (options_.scene_idle_ttl_s > 0) reaper_ = std::thread([this] { reap_idle_scenes(); });
}

RenderService::~RenderService() {
  begin_shutdown();
  if (reaper_.joinable()) reaper_.join();
}

void RenderService::begin_shutdown() {
  {
    std::lock_guard<std::mutex> lock(reaper_mutex_);
    shutting_down_ = true;
  }
  reaper_wake_.notify_all();
  for (const auto& device : devices_) device->queue.shut_down();
}

void RenderService::reap_idle_scenes() {
  const auto ttl = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(options_.scene_idle_ttl_s));
  // Looks often enough that a scene outlives its TTL by at most a quarter of it (or a second).
  const auto period = std::min<Clock::duration>(ttl / 4, std::chrono::seconds(1));
  std::unique_lock<std::mutex> lock(reaper_mutex_);
  while (!reaper_wake_.wait_for(lock, period, [this] { return shutting_down_.load(); })) {
    lock.unlock();
    const auto now = Clock::now();
    for (const std::shared_ptr<SceneEntry>& entry : registry_.list_all()) {
      if (now - entry->last_used() < ttl) continue;
      absl::StatusOr<size_t> freed = forget(*entry);
      if (freed.ok()) {
        log_line(LogLevel::kInfo,
                 absl::StrFormat("scene %s (tenant '%s') idle for %.0f s, deleted "
                                 "(--scene-idle-ttl); %d bytes freed",
                                 entry->id(), entry->tenant(),
                                 std::chrono::duration<double>(now - entry->last_used()).count(),
                                 *freed));
      }
    }
    lock.lock();
  }
}

class RenderService::StreamSlot {
 public:
  StreamSlot(RenderService& service, std::string tenant)
      : service_(service), tenant_(std::move(tenant)) {}
  ~StreamSlot() {
    std::lock_guard<std::mutex> lock(service_.streams_mutex_);
    --service_.tenant_streams_[tenant_];
  }

 private:
  RenderService& service_;
  const std::string tenant_;
};

absl::StatusOr<std::unique_ptr<RenderService::StreamSlot>> RenderService::open_stream(
    const std::string& tenant) {
  std::lock_guard<std::mutex> lock(streams_mutex_);
  uint32_t& open = tenant_streams_[tenant];
  if (options_.max_tenant_streams > 0 && open >= options_.max_tenant_streams) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "tenant '%s' has its maximum of %d frame streams open (--tenant-max-streams); end one "
        "first",
        tenant, options_.max_tenant_streams));
  }
  ++open;
  return std::make_unique<StreamSlot>(*this, tenant);
}

uint32_t RenderService::tenant_streams(const std::string& tenant) const {
  std::lock_guard<std::mutex> lock(streams_mutex_);
  auto it = tenant_streams_.find(tenant);
  return it == tenant_streams_.end() ? 0 : it->second;
}

size_t RenderService::tenant_bytes(const std::string& tenant) const {
  size_t bytes = 0;
  for (const auto& entry : registry_.list(tenant)) bytes += entry->info().device_bytes();
  return bytes;
}

absl::Status RenderService::check_tenant_share(const std::string& tenant, size_t bytes,
                                               const std::string& what) const {
  if (options_.tenant_memory_share >= 1) return absl::OkStatus();  // the budget alone rules
  const size_t limit = tenant_memory_limit();
  const size_t held = tenant_bytes(tenant);
  if (held + bytes <= limit) return absl::OkStatus();
  return absl::ResourceExhaustedError(
      absl::StrCat(what, ", but tenant '", tenant, "' already holds ", mib(held), " of its ",
                   mib(limit), " share of the budget (--tenant-memory-share)"));
}

size_t RenderService::tenant_memory_limit() const {
  return static_cast<size_t>(static_cast<double>(memory_budget()) *
                             std::clamp(options_.tenant_memory_share, 0.0, 1.0));
}

size_t RenderService::sum_over_devices(size_t (Backend::*bytes)() const) const {
  size_t sum = 0;
  for (const auto& device : devices_) sum += (device->backend.get()->*bytes)();
  return sum;
}

size_t RenderService::memory_used() const { return sum_over_devices(&Backend::bytes_in_use); }
size_t RenderService::memory_peak() const { return sum_over_devices(&Backend::peak_bytes); }
size_t RenderService::memory_budget() const { return sum_over_devices(&Backend::budget); }

absl::StatusOr<std::vector<uint32_t>> RenderService::place(size_t bytes, const std::string& what) {
  std::lock_guard<std::mutex> lock(placement_mutex_);
  auto free_bytes = [&](uint32_t index) {
    const Device& device = *devices_[index];
    const size_t taken = device.backend->bytes_in_use() + device.reserved_bytes;
    const size_t budget = device.backend->budget();
    return budget > taken ? budget - taken : 0;
  };
  std::vector<uint32_t> placed;
  if (options_.split_frames) {
    for (uint32_t i = 0; i < devices_.size(); ++i) placed.push_back(i);
  } else {
    uint32_t best = 0;
    for (uint32_t i = 1; i < devices_.size(); ++i) {
      if (free_bytes(i) > free_bytes(best)) best = i;
    }
    placed.push_back(best);
  }
  // Each device of the scene holds all of it.
  for (uint32_t index : placed) {
    const size_t free = free_bytes(index);
    if (bytes <= free) continue;
    const size_t budget = devices_[index]->backend->budget();
    return absl::ResourceExhaustedError(
        devices_.size() == 1
            ? absl::StrCat(what, ", but only ", mib(free), " of the device's ", mib(budget),
                           " budget are free (--memory-budget)")
            : absl::StrCat(what, ", but only ", mib(free), " of device ", index, "'s ", mib(budget),
                           " budget are free",
                           options_.split_frames ? " (--split-frames puts it on every device"
                                                 : " (the most of any device",
                           "; --memory-budget applies per device)"));
  }
  for (uint32_t index : placed) devices_[index]->reserved_bytes += bytes;
  return placed;
}

void RenderService::unreserve(const std::vector<uint32_t>& devices, size_t bytes) {
  std::lock_guard<std::mutex> lock(placement_mutex_);
  for (uint32_t index : devices) devices_[index]->reserved_bytes -= bytes;
}

absl::StatusOr<std::unique_ptr<Engine>> RenderService::create_engine(
    const std::vector<uint32_t>& devices) const {
  std::vector<std::shared_ptr<Backend>> backends;
  for (uint32_t index : devices) backends.push_back(devices_[index]->backend);
  return Engine::create({.backends = std::move(backends)});
}

grpc::Status RenderService::serve(grpc::ServerContext* context, const char* method,
                                  const std::string& scene_id,
                                  const std::function<absl::Status(const std::string&)>& work) {
  ScopedCount running(calls_in_flight_);
  const auto start = Clock::now();
  absl::Status status;
  absl::StatusOr<std::string> tenant = caller_tenant(*context);
  if (!tenant.ok()) {
    status = tenant.status();
  } else if (shutting_down_) {
    status = absl::UnavailableError("the server is shutting down");
  } else if (restoring_ && std::string_view(method) != "GetVersion" &&
             std::string_view(method) != "GetStats") {
    status = absl::UnavailableError(absl::StrFormat(
        "the server is restoring its scenes from --data-dir (%d of %d done); retry shortly",
        restore_done_.load(), restore_total_.load()));
  } else {
    status = work(*tenant);
  }
  const double ms = ms_since(start);
  latencies_.record(absl::StrCat("rpc/", method), ms);
  metrics_.record_call(method, status.code(), ms);
  ++requests_served_;
  const LogLevel level = status.ok() || absl::IsCancelled(status) || absl::IsNotFound(status)
                             ? LogLevel::kInfo
                             : LogLevel::kWarning;
  // The scene id and the status (which may quote the request) are the client's own bytes. Not
  // formatted at all when the level is off: a frame call is a few milliseconds.
  if (log_enabled(level)) {
    log_line(level,
             absl::StrFormat("%s scene=%s tenant=%s peer=%s %.2f ms %s", method,
                             scene_id.empty() ? "-" : printable(scene_id),
                             tenant.ok() && !tenant->empty() ? *tenant : "-", context->peer(), ms,
                             status.ok() ? "OK" : printable(status.ToString())));
  }
  return to_grpc(status);
}

absl::Status RenderService::stop_status(grpc::ServerContext* context) const {
  if (shutting_down_) return absl::UnavailableError("the server is shutting down");
  if (context->IsCancelled()) {
    if (context->deadline() <= std::chrono::system_clock::now()) {
      return absl::DeadlineExceededError("the call's deadline passed");
    }
    return absl::CancelledError("the client cancelled the call");
  }
  return absl::OkStatus();
}

absl::StatusOr<RenderService::Leases> RenderService::acquire_devices(
    const std::vector<uint32_t>& devices, const DeviceQueue::StopCheck& stop) {
  const auto start = Clock::now();
  Leases leases;
  // Ascending order everywhere: a call holding device 0 and waiting for 1 never waits for one
  // that holds 1 and waits for 0. Leases already held are given back if a later wait gives up.
  for (uint32_t index : devices) {
    absl::StatusOr<DeviceQueue::Lease> lease = devices_[index]->queue.acquire(stop);
    if (!lease.ok()) return lease.status();
    leases.held_.push_back(*std::move(lease));
  }
  leases.waited_ms_ = ms_since(start);
  return leases;
}

absl::StatusOr<RenderService::Leases> RenderService::acquire(grpc::ServerContext* context,
                                                             const SceneEntry& entry,
                                                             double* queue_ms) {
  absl::StatusOr<Leases> lease =
      acquire_devices(entry.devices(), [this, context] { return stop_status(context); });
  if (!lease.ok()) return lease.status();
  record_stage("queue", lease->waited_ms());
  if (queue_ms != nullptr) *queue_ms += lease->waited_ms();
  if (!entry.engine) {
    return absl::NotFoundError(absl::StrCat("scene_id: scene '", entry.id(), "' was deleted"));
  }
  entry.touch();  // a long stream keeps its scene from --scene-idle-ttl
  return lease;
}

void RenderService::record_stages(const StageTimings& t) {
  // Stages a call did not run stay out of the percentiles.
  const std::pair<const char*, double> stages[] = {
      {"structure_build", t.structure_build_ms},
      {"photon_trace", t.photon_trace_ms},
      {"photon_map_build", t.photon_map_build_ms},
      {"render", t.render_ms},
  };
  for (const auto& [name, ms] : stages) {
    if (ms > 0) record_stage(name, ms);
  }
}

void RenderService::record_stage(const char* stage, double ms) {
  latencies_.record(absl::StrCat("stage/", stage), ms);
  metrics_.record_stage(stage, ms);
}

absl::StatusOr<v1::RebuildReport> RenderService::rebuild(
    grpc::ServerContext* context, SceneEntry& entry,
    const std::function<absl::StatusOr<RebuildReport>(Engine&)>& change) {
  double queue_ms = 0;
  absl::StatusOr<Leases> lease = acquire(context, entry, &queue_ms);
  if (!lease.ok()) return lease.status();
  absl::StatusOr<RebuildReport> report = change(*entry.engine);
  if (!report.ok()) return report.status();
  if (absl::Status stored = persist(entry); !stored.ok()) return stored;
  record_stages(report->timings);
  v1::RebuildReport out = encode_rebuild(*report);
  out.mutable_timings()->set_queue_ms(queue_ms);
  entry.refresh(&out);
  return out;
}

absl::StatusOr<RenderService::EncodedFrame> RenderService::produce_frame(
    grpc::ServerContext* context, SceneEntry& entry, uint32_t target, uint32_t max_passes,
    const FrameSpec& spec) {
  EncodedFrame frame;
  v1::StageTimings* timings = frame.header.mutable_timings();
  double queue_ms = 0;
  uint64_t photons = 0;
  uint32_t rendered = 0;
  // Raw pixels are copied straight from the film's host image into the frame, under the lease;
  // an image file (PNG, JPEG, EXR) is encoded from a copy after the lease is given back, so that
  // other clients' passes need not wait for the encoder.
  absl::StatusOr<std::string> data;
  std::vector<Rgba8> srgb8;
  std::vector<float> linear;
  int width = 0, height = 0;
  double resolve_ms = 0;
  while (true) {
    if (absl::Status stop = stop_status(context); !stop.ok()) return stop;
    absl::StatusOr<Leases> lease = acquire(context, entry, &queue_ms);
    if (!lease.ok()) return lease.status();
    Engine& engine = *entry.engine;
    const uint32_t goal = target > 0 ? target : std::max(engine.scene().settings.passes, 1u);
    auto wants_pass = [&] { return engine.film_passes() < goal && rendered < max_passes; };
    if (wants_pass()) {
      absl::StatusOr<PassReport> pass = engine.render(1);
      if (!pass.ok()) return pass.status();
      ++rendered;
      photons += pass->photons_emitted;
      add_timings(pass->timings, timings);
      record_stages(pass->timings);
      entry.refresh();
      // Back in line for the next pass, so other clients' passes interleave with ours.
      if (wants_pass()) continue;
    }
    // Resolve under the same lease: the film must not change while it is read.
    const auto resolve_start = Clock::now();
    width = engine.scene().camera.width;
    height = engine.scene().camera.height;
    std::span<const Rgba8> srgb8_image;
    std::span<const float> linear_image;
    if (spec.wants_srgb8()) {
      srgb8_image = engine.image_srgb8(spec.exposure_stops);
    } else {
      linear_image = engine.image_linear();
    }
    if (spec.raw()) {
      data = encode_frame(spec, width, height, srgb8_image, linear_image);
    } else {
      srgb8.assign(srgb8_image.begin(), srgb8_image.end());
      linear.assign(linear_image.begin(), linear_image.end());
    }
    frame.header.set_passes(engine.film_passes());
    *frame.header.mutable_epochs() = encode_epochs(engine.epochs());
    resolve_ms = ms_since(resolve_start);
    break;
  }
  const auto encode_start = Clock::now();
  if (!spec.raw()) data = encode_frame(spec, width, height, srgb8, linear, &frame.header);
  if (!data.ok()) return data.status();
  frame.data = *std::move(data);
  const double encode_ms = spec.raw() ? 0.0 : ms_since(encode_start);
  timings->set_encode_ms(encode_ms);
  timings->set_resolve_ms(resolve_ms + encode_ms);
  timings->set_queue_ms(queue_ms);
  record_stage("resolve", timings->resolve_ms());
  frame.header.set_scene_id(entry.id());
  frame.header.set_width(static_cast<uint32_t>(width));
  frame.header.set_height(static_cast<uint32_t>(height));
  frame.header.set_pixel_format(spec.pixel_format);
  frame.header.set_encoding(spec.encoding);
  frame.header.set_photons_emitted(photons);
  return frame;
}

absl::Status RenderService::send_frame(grpc::ServerWriter<v1::Frame>* writer, EncodedFrame& frame,
                                       size_t chunk_bytes, uint64_t frame_number) {
  frame.header.set_frame_number(frame_number);
  const bool written =
      for_each_frame_chunk(frame.header, frame.data, chunk_bytes,
                           [writer](const v1::Frame& piece) { return writer->Write(piece); });
  if (!written) return absl::CancelledError("the client stopped reading frames");
  ++frames_served_;
  return absl::OkStatus();
}

size_t RenderService::chunk_bytes(uint32_t requested) const {
  return frame_chunk_bytes(requested, options_.max_message_bytes);
}

// --- scenes ---

grpc::Status RenderService::UploadScene(grpc::ServerContext* context,
                                        grpc::ServerReader<v1::SceneChunk>* reader,
                                        v1::SceneInfo* response) {
  std::string scene_id;
  return serve(context, "UploadScene", scene_id, [&](const std::string& tenant) -> absl::Status {
    absl::StatusOr<SceneRegistry::Slot> slot = registry_.reserve(tenant);
    if (!slot.ok()) return slot.status();
    const auto start = Clock::now();
    wire::SceneAssembler assembler;
    // Where the scene goes, chosen at its header; the declared bytes stay reserved there until
    // the scene is built (or the upload fails).
    std::optional<std::vector<uint32_t>> placed;
    size_t reserved = 0;
    absl::Cleanup unreserve_placement = [&] {
      if (placed) unreserve(*placed, reserved);
    };
    auto place_scene = [&](size_t declared) -> absl::Status {
      absl::StatusOr<std::vector<uint32_t>> devices = place(
          declared,
          absl::StrCat("scene '", assembler.name(), "' declares ", mib(declared), " of mesh data"));
      if (!devices.ok()) return devices.status();
      placed = *std::move(devices);
      reserved = declared;
      return absl::OkStatus();
    };
    v1::SceneChunk chunk;
    while (reader->Read(&chunk)) {
      if (absl::Status added = assembler.add(chunk); !added.ok()) return added;
      if (!placed && assembler.has_header()) {
        // Refuse before the mesh data arrives: the scene's arrays alone must fit in what is left
        // of the budget (the built structure needs more on top).
        if (absl::Status fits = place_scene(assembler.bytes_declared()); !fits.ok()) return fits;
        if (absl::Status fits =
                check_tenant_share(tenant, assembler.bytes_declared(),
                                   absl::StrCat("scene '", assembler.name(), "' declares ",
                                                mib(assembler.bytes_declared()), " of mesh data"));
            !fits.ok()) {
          return fits;
        }
      }
      if (absl::Status stop = stop_status(context); !stop.ok()) return stop;
    }
    // Read() also ends when the client goes away; a broken stream keeps nothing.
    if (absl::Status stop = stop_status(context); !stop.ok()) return stop;
    absl::StatusOr<Scene> scene = assembler.finish();
    if (!scene.ok()) return scene.status();
    // Texture files are decoded here, so that one that cannot be read is refused by name before
    // anything is stored; their texels count against the tenant's share like the mesh data.
    if (absl::Status decoded = decode_textures(*scene); !decoded.ok()) return decoded;
    if (const size_t texels = decoded_texture_bytes(*scene); texels > 0) {
      if (absl::Status fits = check_tenant_share(
              tenant, assembler.bytes_declared() + texels,
              absl::StrCat("scene '", assembler.name(), "' declares ",
                           mib(assembler.bytes_declared()),
                           " of mesh data and its textures decode to ", mib(texels)));
          !fits.ok()) {
        return fits;
      }
    }
    if (!placed) {
      if (absl::Status fits = place_scene(0); !fits.ok()) return fits;
    }
    // The geometry goes to disk before the device is taken: writing it need not hold up others.
    std::string blob;
    if (options_.store) {
      absl::StatusOr<std::string> written = options_.store->write_blob(*scene, assembler.name());
      if (!written.ok()) return written.status();
      blob = *std::move(written);
    }
    // A failed upload leaves no blob behind (one another scene shares stays).
    absl::Cleanup discard_blob = [&] {
      if (!blob.empty()) options_.store->discard_blob(blob);
    };

    absl::StatusOr<Leases> lease =
        acquire_devices(*placed, [this, context] { return stop_status(context); });
    if (!lease.ok()) return lease.status();
    absl::StatusOr<std::unique_ptr<Engine>> engine = create_engine(*placed);
    if (!engine.ok()) return engine.status();
    absl::StatusOr<RebuildReport> built = (*engine)->load(*scene);
    if (built.ok()) {
      // The built structure and film count too, which the declared mesh bytes did not show.
      const size_t bytes = (*engine)->scene_stats().device_bytes;
      if (absl::Status fits = check_tenant_share(
              tenant, bytes,
              absl::StrCat("scene '", assembler.name(), "' needs ", mib(bytes), " on the device"));
          !fits.ok()) {
        built = fits;
      }
    }
    // A scene the client can no longer learn the id of would be unreachable; drop it.
    absl::Status stop = stop_status(context);
    if (!built.ok() || !stop.ok()) {
      engine->reset();  // frees its device memory while this call holds the device
      return built.ok() ? stop : built.status();
    }
    v1::SceneInfo info;
    info.set_name(assembler.name());
    info.set_upload_bytes(assembler.bytes_received());
    info.set_upload_ms(ms_since(start));
    describe_geometry(*scene, &info);
    scene_id = registry_.new_id();
    if (options_.store) {
      // Stored before it is acknowledged: once the client has the id, a restart keeps the scene.
      absl::Status stored = options_.store->add({.id = scene_id,
                                                 .tenant = tenant,
                                                 .name = assembler.name(),
                                                 .blob = blob,
                                                 .lights = scene->lights,
                                                 .camera = scene->camera,
                                                 .settings = scene->settings,
                                                 .epochs = built->epochs,
                                                 .upload_bytes = assembler.bytes_received(),
                                                 .upload_ms = info.upload_ms()});
      if (!stored.ok()) {
        engine->reset();
        return stored;
      }
      std::move(discard_blob).Cancel();
    }
    v1::RebuildReport report = encode_rebuild(*built);
    report.mutable_timings()->set_queue_ms(lease->waited_ms());
    record_stages(built->timings);
    auto entry = std::make_shared<SceneEntry>(scene_id, tenant, *placed, *std::move(engine),
                                              std::move(info));
    entry->refresh(&report);
    lease->release();
    *response = entry->info();
    registry_.add(*std::move(slot), std::move(entry));
    return absl::OkStatus();
  });
}

absl::Status RenderService::persist(const SceneEntry& entry) {
  if (!options_.store) return absl::OkStatus();
  absl::Status stored = options_.store->update(entry.id(), entry.engine->scene(),
                                               entry.engine->placements(), entry.engine->epochs());
  if (stored.ok()) return stored;
  return absl::InternalError(absl::StrCat(
      "the change was applied but could not be stored in --data-dir, so a restart would undo "
      "it: ",
      stored.message()));
}

size_t RenderService::restore_scenes() {
  if (!options_.store) return 0;
  const auto start = Clock::now();
  size_t restored = 0;
  absl::StatusOr<std::vector<StoredScene>> stored = options_.store->list();
  if (!stored.ok()) {
    log_line(LogLevel::kError,
             absl::StrCat("--data-dir: cannot read the scene index: ", stored.status().message()));
  } else {
    restore_total_ = stored->size();
    const char* delay = std::getenv(kRestoreDelayVariable);
    for (const StoredScene& scene : *stored) {
      if (delay != nullptr)
        std::this_thread::sleep_for(std::chrono::milliseconds(std::atoi(delay)));
      if (shutting_down_) break;
      if (absl::Status status = restore_scene(scene); status.ok()) {
        ++restored;
      } else {
        registry_.keep_id(scene.id);
        log_line(LogLevel::kError,
                 absl::StrFormat("--data-dir: scene %s ('%s') not restored: %s", scene.id,
                                 printable(scene.name), printable(status.ToString())));
      }
      ++restore_done_;
    }
  }
  log_line(LogLevel::kInfo, absl::StrFormat("--data-dir %s: restored %d of %d scenes in %.1f ms",
                                            options_.store->dir().string(), restored,
                                            restore_total_.load(), ms_since(start)));
  restoring_ = false;
  return restored;
}

absl::Status RenderService::restore_scene(const StoredScene& stored) {
  absl::StatusOr<Scene> geometry = options_.store->read_blob(stored.blob);
  if (!geometry.ok()) return geometry.status();
  if (absl::Status decoded = decode_textures(*geometry); !decoded.ok()) return decoded;
  const Scene scene = restored_scene(*std::move(geometry), stored);
  // Placed afresh, as an upload now would be: the devices may differ from the last run's.
  absl::StatusOr<std::vector<uint32_t>> placed =
      place(0, absl::StrCat("scene '", stored.name, "'"));
  if (!placed.ok()) return placed.status();
  absl::StatusOr<Leases> lease = acquire_devices(*placed, {});
  if (!lease.ok()) return lease.status();
  absl::StatusOr<std::unique_ptr<Engine>> engine = create_engine(*placed);
  if (!engine.ok()) return engine.status();
  absl::StatusOr<RebuildReport> built = (*engine)->load(scene);
  if (!built.ok()) return built.status();
  // The meshes UpdateGeometry moved go where they were.
  if (!stored.placements.empty()) {
    absl::StatusOr<RebuildReport> placed_meshes = (*engine)->set_geometry(stored.placements);
    if (!placed_meshes.ok()) return placed_meshes.status();
  }
  (*engine)->restore_epochs(stored.epochs);
  built->epochs = stored.epochs;
  record_stages(built->timings);
  v1::SceneInfo info;
  info.set_name(stored.name);
  info.set_upload_bytes(stored.upload_bytes);
  info.set_upload_ms(stored.upload_ms);
  describe_geometry(scene, &info);
  const v1::RebuildReport report = encode_rebuild(*built);
  auto entry = std::make_shared<SceneEntry>(stored.id, stored.tenant, *placed, *std::move(engine),
                                            std::move(info));
  entry->refresh(&report);
  registry_.add_restored(std::move(entry));
  return absl::OkStatus();
}

grpc::Status RenderService::ListScenes(grpc::ServerContext* context,
                                       const v1::ListScenesRequest* request,
                                       v1::ListScenesResponse* response) {
  return serve(context, "ListScenes", "", [&](const std::string& tenant) -> absl::Status {
    for (const auto& entry : registry_.list(tenant)) *response->add_scenes() = entry->info();
    return absl::OkStatus();
  });
}

grpc::Status RenderService::GetScene(grpc::ServerContext* context,
                                     const v1::GetSceneRequest* request, v1::SceneInfo* response) {
  return serve(context, "GetScene", request->scene_id(),
               [&](const std::string& tenant) -> absl::Status {
                 absl::StatusOr<std::shared_ptr<SceneEntry>> entry =
                     registry_.find(request->scene_id(), tenant);
                 if (!entry.ok()) return entry.status();
                 *response = (*entry)->info();
                 return absl::OkStatus();
               });
}

grpc::Status RenderService::DeleteScene(grpc::ServerContext* context,
                                        const v1::DeleteSceneRequest* request,
                                        v1::DeleteSceneResponse* response) {
  return serve(context, "DeleteScene", request->scene_id(),
               [&](const std::string& tenant) -> absl::Status {
                 absl::StatusOr<std::shared_ptr<SceneEntry>> entry =
                     registry_.find(request->scene_id(), tenant);
                 if (!entry.ok()) return entry.status();
                 absl::StatusOr<size_t> freed = forget(**entry);
                 if (!freed.ok()) return freed.status();
                 response->set_bytes_freed(*freed);
                 return absl::OkStatus();
               });
}

absl::StatusOr<size_t> RenderService::forget(SceneEntry& entry) {
  // Forgotten on disk first: a delete that could not be stored leaves the scene in place.
  if (options_.store) {
    if (absl::Status removed = options_.store->remove(entry.id()); !removed.ok()) return removed;
  }
  if (!registry_.remove(entry)) {
    return absl::NotFoundError(absl::StrCat("scene_id: scene '", entry.id(), "' was deleted"));
  }
  // Not cancellable: the scene is already gone from the registry and its memory must be freed
  // under its devices' leases. Only shutdown ends the wait (the process frees everything then).
  absl::StatusOr<Leases> lease = acquire_devices(entry.devices(), {});
  if (!lease.ok()) return lease.status();
  auto in_use = [&] {
    size_t bytes = 0;
    for (uint32_t index : entry.devices()) bytes += devices_[index]->backend->bytes_in_use();
    return bytes;
  };
  const size_t before = in_use();
  entry.engine.reset();
  const size_t after = in_use();
  return before > after ? before - after : 0;
}

// --- updates ---

grpc::Status RenderService::serve_update(
    grpc::ServerContext* context, const char* method, const std::string& scene_id,
    v1::RebuildReport* response,
    const std::function<absl::StatusOr<RebuildReport>(Engine&)>& change) {
  return serve(context, method, scene_id, [&](const std::string& tenant) -> absl::Status {
    absl::StatusOr<std::shared_ptr<SceneEntry>> entry = registry_.find(scene_id, tenant);
    if (!entry.ok()) return entry.status();
    absl::StatusOr<v1::RebuildReport> report = rebuild(context, **entry, change);
    if (!report.ok()) return report.status();
    *response = *std::move(report);
    return absl::OkStatus();
  });
}

grpc::Status RenderService::UpdateLights(grpc::ServerContext* context,
                                         const v1::UpdateLightsRequest* request,
                                         v1::RebuildReport* response) {
  return serve_update(
      context, "UpdateLights", request->scene_id(), response,
      [&](Engine& engine) -> absl::StatusOr<RebuildReport> {
        absl::StatusOr<SceneChange> change = decode_change(*request);
        if (!change.ok()) return change.status();
        // Checked under the lease so no other update can slip in between check and change.
        if (request->has_expected_lights_epoch() &&
            engine.epochs().lights != request->expected_lights_epoch()) {
          return absl::FailedPreconditionError(absl::StrFormat(
              "expected_lights_epoch: the scene's lights epoch is %d, not %d (another call "
              "changed the lights)",
              engine.epochs().lights, request->expected_lights_epoch()));
        }
        return engine.apply(*change);
      });
}

absl::Status RenderService::check_geometry_room(const std::string& tenant, const SceneEntry& entry,
                                                const Engine& engine) const {
  const size_t bytes = engine.geometry_change_bytes();
  return check_tenant_share(tenant, bytes,
                            absl::StrCat("the geometry change of scene '", entry.info().name(),
                                         "' builds ", mib(bytes), " beside it"));
}

absl::StatusOr<v1::RebuildReport> RenderService::change_geometry(
    grpc::ServerContext* context, const std::string& tenant,
    const v1::UpdateGeometryRequest& request) {
  absl::StatusOr<std::shared_ptr<SceneEntry>> entry = registry_.find(request.scene_id(), tenant);
  if (!entry.ok()) return entry.status();
  absl::StatusOr<std::vector<MeshChange>> changes =
      wire::decode_mesh_changes(request.meshes(), "meshes");
  if (!changes.ok()) return changes.status();
  // Checked under the lease, so that no other update can slip in between check and change.
  return rebuild(context, **entry, [&](Engine& engine) -> absl::StatusOr<RebuildReport> {
    if (request.has_expected_geometry_epoch() &&
        engine.epochs().geometry != request.expected_geometry_epoch()) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "expected_geometry_epoch: the scene's geometry epoch is %d, not %d (another call "
          "changed the geometry)",
          engine.epochs().geometry, request.expected_geometry_epoch()));
    }
    if (absl::Status room = check_geometry_room(tenant, **entry, engine); !room.ok()) return room;
    return engine.set_geometry(*changes);
  });
}

grpc::Status RenderService::UpdateGeometry(grpc::ServerContext* context,
                                           const v1::UpdateGeometryRequest* request,
                                           v1::RebuildReport* response) {
  return serve(context, "UpdateGeometry", request->scene_id(),
               [&](const std::string& tenant) -> absl::Status {
                 absl::StatusOr<v1::RebuildReport> report =
                     change_geometry(context, tenant, *request);
                 if (!report.ok()) return report.status();
                 *response = *std::move(report);
                 return absl::OkStatus();
               });
}

grpc::Status RenderService::StreamGeometry(grpc::ServerContext* context,
                                           grpc::ServerReader<v1::GeometryChunk>* reader,
                                           v1::RebuildReport* response) {
  std::string scene_id;
  return serve(context, "StreamGeometry", scene_id, [&](const std::string& tenant) -> absl::Status {
    GeometryAssembler assembler;
    v1::GeometryChunk chunk;
    while (reader->Read(&chunk)) {
      if (absl::Status added = assembler.add(chunk); !added.ok()) return added;
      if (absl::Status stop = stop_status(context); !stop.ok()) return stop;
    }
    // Read() also ends when the client goes away; a broken stream changes nothing.
    if (absl::Status stop = stop_status(context); !stop.ok()) return stop;
    absl::StatusOr<v1::UpdateGeometryRequest> request = assembler.finish();
    if (!request.ok()) return request.status();
    scene_id = request->scene_id();
    absl::StatusOr<v1::RebuildReport> report = change_geometry(context, tenant, *request);
    if (!report.ok()) return report.status();
    *response = *std::move(report);
    return absl::OkStatus();
  });
}

grpc::Status RenderService::UpdateCamera(grpc::ServerContext* context,
                                         const v1::UpdateCameraRequest* request,
                                         v1::RebuildReport* response) {
  return serve_update(context, "UpdateCamera", request->scene_id(), response,
                      [&](Engine& engine) -> absl::StatusOr<RebuildReport> {
                        if (!request->has_camera()) {
                          return absl::InvalidArgumentError("camera: is missing");
                        }
                        absl::StatusOr<Camera> camera =
                            wire::decode_camera(request->camera(), "camera");
                        if (!camera.ok()) return camera.status();
                        return engine.set_camera(*camera);
                      });
}

grpc::Status RenderService::UpdateSettings(grpc::ServerContext* context,
                                           const v1::UpdateSettingsRequest* request,
                                           v1::RebuildReport* response) {
  return serve_update(
      context, "UpdateSettings", request->scene_id(), response,
      [&](Engine& engine) -> absl::StatusOr<RebuildReport> {
        absl::StatusOr<RenderSettings> settings =
            wire::apply_settings(request->settings(), engine.scene().settings, "settings");
        if (!settings.ok()) return settings.status();
        return engine.set_settings(*settings, {request->width(), request->height()});
      });
}

// --- frames ---

absl::StatusOr<RenderService::FrameCall> RenderService::start_frames(const std::string& tenant,
                                                                     const std::string& scene_id,
                                                                     const v1::FrameFormat& format,
                                                                     bool stream) {
  absl::StatusOr<std::shared_ptr<SceneEntry>> entry = registry_.find(scene_id, tenant);
  if (!entry.ok()) return entry.status();
  absl::StatusOr<FrameSpec> spec = parse_frame_format(format, "format");
  if (!spec.ok()) return spec.status();
  FrameCall call{*std::move(entry), *spec};
  if (stream) {
    absl::StatusOr<std::unique_ptr<StreamSlot>> slot = open_stream(tenant);
    if (!slot.ok()) return slot.status();
    call.stream = *std::move(slot);
  }
  return call;
}

grpc::Status RenderService::RenderFrame(grpc::ServerContext* context,
                                        const v1::RenderFrameRequest* request,
                                        v1::Frame* response) {
  return serve(
      context, "RenderFrame", request->scene_id(), [&](const std::string& tenant) -> absl::Status {
        absl::StatusOr<FrameCall> call =
            start_frames(tenant, request->scene_id(), request->format(), /*stream=*/false);
        if (!call.ok()) return call.status();
        SceneEntry& entry = *call->entry;
        const FrameSpec& spec = call->spec;
        absl::StatusOr<EncodedFrame> frame =
            produce_frame(context, entry, request->target_passes(), kAllPasses, spec);
        if (!frame.ok()) return frame.status();
        if (frame->data.size() + kFrameHeaderRoom > options_.max_message_bytes) {
          return absl::ResourceExhaustedError(absl::StrFormat(
              "the frame is %s, over the server's message limit of %s (--max-message-mb); use "
              "StreamFrames, which splits frames",
              mib(frame->data.size()), mib(options_.max_message_bytes)));
        }
        *response = std::move(frame->header);
        response->set_data_size(frame->data.size());
        response->set_last_chunk(true);
        response->set_data(std::move(frame->data));
        ++frames_served_;
        return absl::OkStatus();
      });
}

grpc::Status RenderService::StreamFrames(grpc::ServerContext* context,
                                         const v1::StreamFramesRequest* request,
                                         grpc::ServerWriter<v1::Frame>* writer) {
  ScopedCount streaming(active_streams_);
  return serve(
      context, "StreamFrames", request->scene_id(), [&](const std::string& tenant) -> absl::Status {
        absl::StatusOr<FrameCall> call =
            start_frames(tenant, request->scene_id(), request->format(), /*stream=*/true);
        if (!call.ok()) return call.status();
        SceneEntry& entry = *call->entry;
        const FrameSpec& spec = call->spec;
        const uint32_t target = std::max(request->target_passes(), 1u);
        const size_t chunk = chunk_bytes(request->max_chunk_bytes());
        if (request->repeat_frames() > 0) {
          // Delivery alone: one resolve, then the same bytes again and again.
          absl::StatusOr<EncodedFrame> frame =
              produce_frame(context, entry, target, kAllPasses, spec);
          if (!frame.ok()) return frame.status();
          for (uint32_t i = 0; i < request->repeat_frames(); ++i) {
            if (absl::Status stop = stop_status(context); !stop.ok()) return stop;
            if (absl::Status sent = send_frame(writer, *frame, chunk, i); !sent.ok()) return sent;
          }
          return absl::OkStatus();
        }
        const uint32_t passes_per_frame = std::max(request->passes_per_frame(), 1u);
        // A change by another call empties the film, so this runs until a frame shows `target`
        // passes of one unchanged scene state.
        for (uint64_t frame_number = 0;; ++frame_number) {
          absl::StatusOr<EncodedFrame> frame =
              produce_frame(context, entry, target, passes_per_frame, spec);
          if (!frame.ok()) return frame.status();
          if (absl::Status sent = send_frame(writer, *frame, chunk, frame_number); !sent.ok()) {
            return sent;
          }
          if (frame->header.passes() >= target) return absl::OkStatus();
        }
      });
}

grpc::Status RenderService::PlayAnimation(grpc::ServerContext* context,
                                          const v1::PlayAnimationRequest* request,
                                          grpc::ServerWriter<v1::Frame>* writer) {
  ScopedCount streaming(active_streams_);
  return serve(
      context, "PlayAnimation", request->scene_id(),
      [&](const std::string& tenant) -> absl::Status {
        absl::StatusOr<FrameCall> call =
            start_frames(tenant, request->scene_id(), request->format(), /*stream=*/true);
        if (!call.ok()) return call.status();
        SceneEntry& entry = *call->entry;
        const FrameSpec& spec = call->spec;
        // Every keyframe is decoded, and checked against the scene, before the first one plays:
        // a bad script changes nothing.
        struct Step {
          SceneChange change;
          std::optional<Camera> camera;
        };
        std::vector<Step> keyframes;
        for (int i = 0; i < request->keyframes_size(); ++i) {
          const v1::Keyframe& keyframe = request->keyframes(i);
          const std::string prefix = absl::StrCat("keyframes[", i, "].");
          absl::StatusOr<SceneChange> change = decode_change(keyframe, prefix);
          if (!change.ok()) return change.status();
          Step step{*std::move(change), std::nullopt};
          if (keyframe.has_camera()) {
            // Its size is the scene's, set when it plays.
            absl::StatusOr<Camera> camera =
                wire::decode_camera_at(keyframe.camera(), prefix + "camera", 0, 0);
            if (!camera.ok()) return camera.status();
            step.camera = *camera;
          }
          keyframes.push_back(std::move(step));
        }
        {
          absl::StatusOr<Leases> lease = acquire(context, entry, nullptr);
          if (!lease.ok()) return lease.status();
          for (size_t i = 0; i < keyframes.size(); ++i) {
            if (absl::Status s = entry.engine->check(keyframes[i].change); !s.ok()) {
              return absl::Status(s.code(), absl::StrCat("keyframes[", i, "].", s.message()));
            }
          }
        }
        const size_t chunk = chunk_bytes(request->max_chunk_bytes());
        for (size_t i = 0; i < keyframes.size(); ++i) {
          absl::StatusOr<v1::RebuildReport> report =
              rebuild(context, entry, [&](Engine& engine) -> absl::StatusOr<RebuildReport> {
                if (std::optional<Camera> camera = keyframes[i].camera) {
                  camera->width = engine.scene().camera.width;
                  camera->height = engine.scene().camera.height;
                  absl::StatusOr<RebuildReport> moved = engine.set_camera(*camera);
                  if (!moved.ok()) return moved.status();
                }
                if (!keyframes[i].change.meshes.empty()) {
                  if (absl::Status room = check_geometry_room(tenant, entry, engine); !room.ok())
                    return absl::Status(room.code(),
                                        absl::StrCat("keyframes[", i, "]: ", room.message()));
                }
                return engine.apply(keyframes[i].change);
              });
          if (!report.ok()) return report.status();
          const uint32_t passes = std::max(request->keyframes(static_cast<int>(i)).passes(), 1u);
          absl::StatusOr<EncodedFrame> frame =
              produce_frame(context, entry, passes, kAllPasses, spec);
          if (!frame.ok()) return frame.status();
          // The frame's cost includes its keyframe's light rebuild.
          add_timings(report->timings(), frame->header.mutable_timings());
          frame->header.set_photons_emitted(frame->header.photons_emitted() +
                                            report->photons_emitted());
          frame->header.set_keyframe(static_cast<uint32_t>(i));
          if (absl::Status sent = send_frame(writer, *frame, chunk, i); !sent.ok()) return sent;
        }
        return absl::OkStatus();
      });
}

// --- stats ---

grpc::Status RenderService::GetVersion(grpc::ServerContext* context, const v1::GetVersionRequest*,
                                       v1::VersionInfo* response) {
  return serve(context, "GetVersion", "", [&](const std::string&) {
    *response = wire::own_version();
    return absl::OkStatus();
  });
}

void RenderService::describe_devices(v1::Stats* response) const {
  std::vector<uint32_t> scenes(devices_.size(), 0);
  for (const std::shared_ptr<SceneEntry>& entry : registry_.list_all()) {
    for (uint32_t index : entry->devices()) ++scenes[index];
  }
  for (uint32_t i = 0; i < devices_.size(); ++i) {
    const Device& device = *devices_[i];
    v1::DeviceStats* out = response->add_devices();
    out->set_index(i);
    out->set_kind(device_kind_name(device.backend->kind()));
    out->set_ordinal(device.info.ordinal);
    out->set_name(device.info.name);
    out->set_compute_units(static_cast<uint32_t>(device.info.compute_units));
    out->set_memory_bytes(device.info.memory_bytes);
    out->set_memory_used_bytes(device.backend->bytes_in_use());
    out->set_memory_budget_bytes(device.backend->budget());
    out->set_memory_peak_bytes(device.backend->peak_bytes());
    out->set_scenes(scenes[i]);
    out->set_queue_waiting(static_cast<uint32_t>(device.queue.waiting()));
  }
  // What clients from before several devices read: the first device, and the sums.
  const v1::DeviceStats& first = response->devices(0);
  v1::DeviceInfo* device = response->mutable_device();
  device->set_kind(first.kind());
  device->set_name(first.name());
  device->set_compute_units(first.compute_units());
  device->set_memory_bytes(first.memory_bytes());
  uint64_t used = 0, budget = 0, peak = 0;
  for (const v1::DeviceStats& each : response->devices()) {
    used += each.memory_used_bytes();
    budget += each.memory_budget_bytes();
    peak += each.memory_peak_bytes();
  }
  response->set_memory_used_bytes(used);
  response->set_memory_budget_bytes(budget);
  response->set_memory_peak_bytes(peak);
}

grpc::Status RenderService::GetStats(grpc::ServerContext* context,
                                     const v1::GetStatsRequest* request, v1::Stats* response) {
  return serve(context, "GetStats", request->scene_id(),
               [&](const std::string& tenant) -> absl::Status {
                 std::vector<std::shared_ptr<SceneEntry>> scenes;
                 if (request->scene_id().empty()) {
                   scenes = registry_.list(tenant);
                 } else {
                   absl::StatusOr<std::shared_ptr<SceneEntry>> entry =
                       registry_.find(request->scene_id(), tenant);
                   if (!entry.ok()) return entry.status();
                   scenes.push_back(*std::move(entry));
                 }
                 response->set_uptime_s(ms_since(started_) / 1000.0);
                 describe_devices(response);
                 response->set_scenes(static_cast<uint32_t>(registry_.size(tenant)));
                 response->set_max_scenes(static_cast<uint32_t>(registry_.max_scenes()));
                 response->set_frames_served(frames_served_);
                 response->set_requests_served(requests_served_);
                 response->set_active_streams(active_streams_);
                 response->set_viewer_port(static_cast<uint32_t>(viewer_port_.load()));
                 response->set_heap_bytes(live_heap_bytes());
                 for (const LatencySummary& s : latencies_.summaries()) {
                   v1::LatencySummary* out = response->add_latencies();
                   out->set_stage(s.name);
                   out->set_count(s.count);
                   out->set_p50_ms(s.p50_ms);
                   out->set_p90_ms(s.p90_ms);
                   out->set_p99_ms(s.p99_ms);
                   out->set_max_ms(s.max_ms);
                 }
                 for (const auto& entry : scenes) *response->add_scene_stats() = entry->info();
                 v1::TenantStats* own = response->mutable_tenant();
                 own->set_name(tenant);
                 own->set_scenes(static_cast<uint32_t>(registry_.size(tenant)));
                 own->set_max_scenes(static_cast<uint32_t>(options_.max_tenant_scenes));
                 own->set_memory_bytes(tenant_bytes(tenant));
                 own->set_memory_limit_bytes(tenant_memory_limit());
                 own->set_active_streams(tenant_streams(tenant));
                 own->set_max_streams(static_cast<uint32_t>(options_.max_tenant_streams));
                 return absl::OkStatus();
               });
}

}  // namespace caustica::server
