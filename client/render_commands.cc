// render SCENE -o OUT (one image) and stream SCENE -o DIR (an image per refinement step). Both
// read StreamFrames: it carries frames of any size in pieces, and with one frame per pass it
// drives the progress bar.
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/frame_image.h"
#include "client/frame_session.h"
#include "client/result_output.h"
#include "client/tev_client.h"

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
  absl::StatusOr<v1::FrameFormat> format = s.frame_format(options.output);
  if (!format.ok()) return format.status();
  *request.mutable_format() = *std::move(format);
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
  if (options.directory.empty() && options.tev.empty()) {
    return absl::InvalidArgumentError("give -o DIR, --tev HOST:PORT or both");
  }
  std::unique_ptr<TevClient> tev;
  if (!options.tev.empty()) {
    if (!options.directory.empty() && options.format != "exr" && options.format != "pfm") {
      return absl::InvalidArgumentError(
          "--tev streams linear float frames: the files beside them need --format exr or pfm");
    }
    // Before the upload, so that a viewer that is not running costs nothing.
    absl::StatusOr<std::unique_ptr<TevClient>> connected = TevClient::connect(options.tev);
    if (!connected.ok()) return connected.status();
    tev = *std::move(connected);
  }
  absl::StatusOr<std::unique_ptr<FrameSession>> session = FrameSession::open(global, options.job);
  if (!session.ok()) return session.status();
  FrameSession& s = **session;

  v1::StreamFramesRequest request;
  request.set_scene_id(s.source().id());
  request.set_target_passes(options.passes);
  request.set_passes_per_frame(options.every);
  absl::StatusOr<v1::FrameFormat> format = s.frame_format(absl::StrCat("frame.", options.format));
  if (!format.ok()) return format.status();
  *request.mutable_format() = *std::move(format);
  if (tev) {
    // tev shows linear radiance and tone-maps itself; files beside it are encoded here.
    request.mutable_format()->set_pixel_format(v1::RGBA32F_LINEAR);
    request.mutable_format()->set_encoding(v1::RAW);
  }
  const std::string tev_image = absl::StrCat("caustica ", s.source().id());
  bool tev_image_created = false;
  s.report_start(out);
  absl::Status status = s.read_stream(
      stream_frames(request), "stream", options.passes, passes_of, [&](v1::Frame& frame) {
        if (tev) {
          const int width = static_cast<int>(frame.width()),
                    height = static_cast<int>(frame.height());
          if (frame.data().size() != size_t(width) * height * 4 * sizeof(float)) {
            return absl::DataLossError("the frame does not hold its RGBA float pixels");
          }
          if (!tev_image_created) {
            if (absl::Status created = tev->create_image(tev_image, width, height); !created.ok())
              return created;
            tev_image_created = true;
          }
          const std::span<const float> rgba(reinterpret_cast<const float*>(frame.data().data()),
                                            frame.data().size() / sizeof(float));
          if (absl::Status shown = tev->update_image(tev_image, width, height, rgba); !shown.ok())
            return shown;
        }
        if (options.directory.empty()) return absl::OkStatus();
        return s.save_frame(
            frame, options.directory, frame.frame_number(), options.format, out,
            absl::StrFormat("%s, render %.1f ms", frame_text(frame), frame.timings().render_ms()));
      });
  if (!status.ok()) return status;
  s.report_end(out, {}, "");
  return absl::OkStatus();
}

}  // namespace caustica::client
