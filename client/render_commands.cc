// render SCENE -o OUT (one image) and stream SCENE -o DIR (an image per refinement step). Both
// read StreamFrames: it carries frames of any size in pieces, and with one frame per pass it
// drives the progress bar.
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/frame_image.h"
#include "client/frame_session.h"
#include "client/result_output.h"

namespace caustica::client {
namespace {

FrameSession::StreamStarter stream_frames(v1::StreamFramesRequest request) {
  return
      [request = std::move(request)](v1::RenderService::Stub& stub, grpc::ClientContext* context) {
        return std::unique_ptr<grpc::ClientReaderInterface<v1::Frame>>(
            stub.StreamFrames(context, request));
      };
}

double passes_of(const v1::Frame& frame) { return frame.passes(); }

}  // namespace

absl::Status run_render(const GlobalOptions& global, const RenderOptions& options,
                        std::ostream& out) {
  absl::StatusOr<std::unique_ptr<FrameSession>> session = FrameSession::open(global, options.job);
  if (!session.ok()) return session.status();
  FrameSession& s = **session;
  const uint32_t passes = options.passes.value_or(s.source().file_passes().value_or(1));

  v1::StreamFramesRequest request;
  request.set_scene_id(s.source().id());
  request.set_target_passes(passes);
  // Frames in between only feed the progress bar; without one, only the final frame comes.
  request.set_passes_per_frame(global.progress ? 1 : passes);
  *request.mutable_format() = s.frame_format(options.output);
  std::optional<v1::Frame> last;
  absl::Status status =
      s.read_stream(stream_frames(request), "render", passes, passes_of, [&](v1::Frame& frame) {
        last = std::move(frame);
        return absl::OkStatus();
      });
  if (!status.ok()) return status;
  if (!last) return absl::DataLossError("the server sent no frame");
  if (absl::Status written = write_frame(*last, options.output); !written.ok()) return written;

  s.report_start(out);
  if (!s.json()) out << absl::StrFormat("frame        %s\n", frame_text(*last));
  s.report_end(out, {{"frame", frame_header_json(*last)}, {"output", options.output.string()}},
               absl::StrFormat("wrote        %s\n", options.output.string()));
  return absl::OkStatus();
}

absl::Status run_stream(const GlobalOptions& global, const StreamOptions& options,
                        std::ostream& out) {
  absl::StatusOr<std::unique_ptr<FrameSession>> session = FrameSession::open(global, options.job);
  if (!session.ok()) return session.status();
  FrameSession& s = **session;

  v1::StreamFramesRequest request;
  request.set_scene_id(s.source().id());
  request.set_target_passes(options.passes);
  request.set_passes_per_frame(options.every);
  *request.mutable_format() = s.frame_format(absl::StrCat("frame.", options.format));
  s.report_start(out);
  absl::Status status = s.read_stream(
      stream_frames(request), "stream", options.passes, passes_of, [&](v1::Frame& frame) {
        return s.save_frame(
            frame, options.directory, frame.frame_number(), options.format, out,
            absl::StrFormat("%s, render %.1f ms", frame_text(frame), frame.timings().render_ms()));
      });
  if (!status.ok()) return status;
  s.report_end(out, {}, "");
  return absl::OkStatus();
}

}  // namespace caustica::client
