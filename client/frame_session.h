// What render, stream and animate share: a connection with the SCENE argument resolved, reading
// a frame stream with a progress bar while summing the per-frame stage timings, and reporting
// the scene, frames and timings as text or JSON.
#pragma once

#include <grpcpp/support/sync_stream.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/commands.h"
#include "client/connection.h"
#include "client/scene_source.h"

namespace caustica::client {

class FrameSession {
 public:
  static absl::StatusOr<std::unique_ptr<FrameSession>> open(const GlobalOptions& global,
                                                            const FrameJobOptions& job);
  // The scene goes before the connection that deletes it.
  ~FrameSession() { source_.reset(); }

  Connection& connection() { return *connection_; }
  const SceneSource& source() const { return *source_; }

  // Starts a frame stream with `start` (a context carrying --timeout is passed in) and reads it
  // to the end. Every whole frame goes to `on_frame`, then advances the progress bar labelled
  // `label` to `progress_of(frame)` out of `progress_total`. Stage timings add up in timings().
  using StreamStarter = std::function<std::unique_ptr<grpc::ClientReaderInterface<v1::Frame>>(
      v1::RenderService::Stub& stub, grpc::ClientContext* context)>;
  absl::Status read_stream(const StreamStarter& start, const std::string& label,
                           double progress_total,
                           const std::function<double(const v1::Frame&)>& progress_of,
                           const std::function<absl::Status(v1::Frame&)>& on_frame);

  const v1::StageTimings& timings() const { return timings_; }
  double wall_ms() const { return wall_ms_; }  // the last stream, from call to end

  // Reporting, as text or (--json) as one JSON object printed by report_end:
  // text: the lines about the scene (upload and build, or a settings update).
  void report_start(std::ostream& out) const;
  // Writes `frame` to DIR/frame_NNNN.<extension> (NNNN = index, DIR created); text: prints
  // "wrote PATH  <detail>"; JSON: adds the frame to the result's "frames".
  absl::Status save_frame(const v1::Frame& frame, const std::filesystem::path& directory,
                          uint64_t index, const std::string& extension, std::ostream& out,
                          const std::string& detail);
  // text: the summed stage timings and the round trip, then `text_tail`; JSON: scene id, upload,
  // settings report, timings, frames and the fields of `extra`.
  void report_end(std::ostream& out, const nlohmann::json& extra,
                  const std::string& text_tail) const;
  bool json() const { return json_; }
  // The format to request for frames that go to files like `output`, with the job's exposure.
  absl::StatusOr<v1::FrameFormat> frame_format(const std::filesystem::path& output) const;

 private:
  FrameSession(const GlobalOptions& global, float exposure_stops)
      : progress_(global.progress), json_(global.json), exposure_stops_(exposure_stops) {}

  bool progress_;
  bool json_;
  float exposure_stops_;
  nlohmann::json frames_ = nlohmann::json::array();
  std::unique_ptr<Connection> connection_;
  std::unique_ptr<SceneSource> source_;
  v1::StageTimings timings_;
  double wall_ms_ = 0;
};

}  // namespace caustica::client
