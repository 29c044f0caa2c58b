// Shared steps of the frame-producing commands (see frame_session.h).
#include "client/frame_session.h"

#include <chrono>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/frame_image.h"
#include "client/frame_stream.h"
#include "client/progress_bar.h"
#include "client/result_output.h"

namespace caustica::client {
namespace {

void add_timings(v1::StageTimings& sum, const v1::StageTimings& t) {
  sum.set_structure_build_ms(sum.structure_build_ms() + t.structure_build_ms());
  sum.set_photon_trace_ms(sum.photon_trace_ms() + t.photon_trace_ms());
  sum.set_photon_map_build_ms(sum.photon_map_build_ms() + t.photon_map_build_ms());
  sum.set_render_ms(sum.render_ms() + t.render_ms());
  sum.set_resolve_ms(sum.resolve_ms() + t.resolve_ms());
  sum.set_queue_ms(sum.queue_ms() + t.queue_ms());
}

}  // namespace

absl::StatusOr<std::unique_ptr<FrameSession>> FrameSession::open(const GlobalOptions& global,
                                                                 const FrameJobOptions& job) {
  std::unique_ptr<FrameSession> session(new FrameSession(global, job.exposure_stops));
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(global.connect);
  if (!connection.ok()) return connection.status();
  session->connection_ = *std::move(connection);
  absl::StatusOr<std::unique_ptr<SceneSource>> source =
      SceneSource::open(*session->connection_, job.scene, job.overrides, job.keep, global.progress);
  if (!source.ok()) return source.status();
  session->source_ = *std::move(source);
  return session;
}

absl::Status FrameSession::read_stream(const StreamStarter& start, const std::string& label,
                                       double progress_total,
                                       const std::function<double(const v1::Frame&)>& progress_of,
                                       const std::function<absl::Status(v1::Frame&)>& on_frame) {
  ProgressBar bar(label, progress_);
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<grpc::ClientContext> context = connection_->new_context();
  std::unique_ptr<grpc::ClientReaderInterface<v1::Frame>> reader =
      start(connection_->stub(), context.get());
  const absl::Status status = receive_frames(*context, *reader, [&](v1::Frame& frame) {
    add_timings(timings_, frame.timings());
    const double done = progress_of(frame);
    const std::string detail = absl::StrFormat("%g/%g", done, progress_total);
    if (absl::Status s = on_frame(frame); !s.ok()) return s;
    bar.update(done, progress_total, detail);
    return absl::OkStatus();
  });
  wall_ms_ =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return status;
}

absl::StatusOr<v1::FrameFormat> FrameSession::frame_format(
    const std::filesystem::path& output) const {
  return frame_format_for(output, exposure_stops_);
}

void FrameSession::report_start(std::ostream& out) const {
  if (json_) return;
  if (const std::optional<v1::SceneInfo>& info = source_->uploaded()) {
    out << absl::StrFormat("scene        '%s' uploaded as %s: %d triangles, %s in %.1f ms\n",
                           info->name(), info->scene_id(), info->triangles(),
                           mib_text(info->upload_bytes()), info->upload_ms());
    out << absl::StrFormat("build (ms)   %s\n", timings_text(info->last_rebuild().timings()));
    out << absl::StrFormat("structure    %s\n", structure_text(*info));
  } else {
    out << absl::StrFormat("scene        %s\n", source_->id());
  }
  if (const std::optional<v1::RebuildReport>& report = source_->settings_report()) {
    out << absl::StrFormat("settings     rebuilt %s: %s ms\n",
                           absl::StrJoin(report->rebuilt(), ", "), timings_text(report->timings()));
  }
}

absl::Status FrameSession::save_frame(const v1::Frame& frame,
                                      const std::filesystem::path& directory, uint64_t index,
                                      const std::string& extension, std::ostream& out,
                                      const std::string& detail) {
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error) {
    return absl::InvalidArgumentError(
        absl::StrCat(directory.string(), ": cannot create directory: ", error.message()));
  }
  const std::filesystem::path path = directory / absl::StrFormat("frame_%04d.%s", index, extension);
  if (absl::Status written = write_frame(frame, path); !written.ok()) return written;
  if (json_) {
    nlohmann::json json = frame_header_json(frame);
    json["output"] = path.string();
    frames_.push_back(std::move(json));
  } else {
    out << absl::StrFormat("wrote        %s  %s\n", path.string(), detail);
  }
  return absl::OkStatus();
}

void FrameSession::report_end(std::ostream& out, const nlohmann::json& extra,
                              const std::string& text_tail) const {
  if (!json_) {
    out << absl::StrFormat("time (ms)    %s | round trip %.1f\n", timings_text(timings_), wall_ms_);
    out << text_tail;
    return;
  }
  nlohmann::json json;
  json["scene_id"] = source_->id();
  if (source_->uploaded()) json["upload"] = to_json(*source_->uploaded());
  if (source_->settings_report()) json["settings_report"] = to_json(*source_->settings_report());
  json["timings"] = to_json(timings_);
  json["round_trip_ms"] = wall_ms_;
  if (!frames_.empty()) json["frames"] = frames_;
  if (extra.is_object()) json.update(extra);
  print_json(out, json);
}

}  // namespace caustica::client
