// animate SCENE --script SCRIPT.json | --gltf-animation NAME -o DIR [--video OUT.mp4]: the server
// plays the keyframed script, or the scene's glTF animation sampled at --fps, or both together
// (PlayAnimation) and streams one frame per keyframe; each becomes
// DIR/frame_NNNN.<format>, and ffmpeg, when on PATH, joins them into a video.
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/animate_fleet.h"
#include "client/frame_session.h"
#include "client/gltf_keyframes.h"
#include "client/light_json.h"
#include "client/result_output.h"
#include "client/scene_source.h"
#include "client/subprocess.h"
#include "renderer/scene/file_io.h"

namespace caustica::client {
namespace {

absl::Status encode_video(const std::filesystem::path& ffmpeg, const AnimateOptions& options) {
  const std::vector<std::string> argv = {
      ffmpeg.string(), "-y", "-loglevel", "error", "-framerate", absl::StrCat(options.fps), "-i",
      (options.directory / absl::StrCat("frame_%04d.", options.format)).string(),
      // H.264 in yuv420p wants even sizes; this plays everywhere.
      "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", options.video.string()};
  absl::StatusOr<pid_t> pid = spawn_process(argv, std::nullopt);
  if (!pid.ok()) return pid.status();
  if (const int exit = wait_exit(*pid); exit != 0) {
    return absl::InternalError(absl::StrCat("ffmpeg exited with status ", exit));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status run_animate(const GlobalOptions& global, const AnimateOptions& options,
                         std::ostream& out) {
  // Everything that can fail without the server fails before any rendering.
  if (options.script.empty() && options.gltf_animation.empty()) {
    return absl::InvalidArgumentError("give --script, --gltf-animation or both");
  }
  absl::StatusOr<std::vector<v1::Keyframe>> keyframes = std::vector<v1::Keyframe>();
  if (!options.script.empty()) {
    absl::StatusOr<std::string> text = read_file(options.script);
    if (!text.ok()) return text.status();
    keyframes = parse_animation_script(*text, options.script.string());
    if (!keyframes.ok()) return keyframes.status();
  }
  if (!options.gltf_animation.empty()) {
    if (!is_scene_file(options.job.scene)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--gltf-animation reads the models of a scene file, and '",
                       options.job.scene, "' is a scene id: give the scene's file"));
    }
    keyframes = gltf_keyframes(options.job.scene, options.gltf_animation, options.fps,
                               *std::move(keyframes));
    if (!keyframes.ok()) return keyframes.status();
  }
  std::optional<std::filesystem::path> ffmpeg;
  if (!options.video.empty() && !(ffmpeg = find_on_path("ffmpeg"))) {
    return absl::FailedPreconditionError(
        "--video needs ffmpeg on PATH, and there is none (install ffmpeg, or leave out --video "
        "to get the frames alone)");
  }

  if (!options.servers.empty()) {
    return run_animate_fleet(
        global, options, *std::move(keyframes),
        [&] { return ffmpeg ? encode_video(*ffmpeg, options) : absl::OkStatus(); }, out);
  }

  absl::StatusOr<std::unique_ptr<FrameSession>> session = FrameSession::open(global, options.job);
  if (!session.ok()) return session.status();
  FrameSession& s = **session;
  v1::PlayAnimationRequest request;
  request.set_scene_id(s.source().id());
  for (v1::Keyframe& keyframe : *keyframes) *request.add_keyframes() = std::move(keyframe);
  absl::StatusOr<v1::FrameFormat> format = s.frame_format(absl::StrCat("frame.", options.format));
  if (!format.ok()) return format.status();
  *request.mutable_format() = *std::move(format);

  s.report_start(out);
  const auto play = [&request](v1::RenderService::Stub& stub, grpc::ClientContext* context) {
    return std::unique_ptr<grpc::ClientReaderInterface<v1::Frame>>(
        stub.PlayAnimation(context, request));
  };
  const auto keyframes_done = [](const v1::Frame& frame) { return frame.keyframe() + 1.0; };
  absl::Status status = s.read_stream(
      play, "animate", request.keyframes_size(), keyframes_done, [&](v1::Frame& frame) {
        return s.save_frame(frame, options.directory, frame.keyframe(), options.format, out,
                            absl::StrFormat("keyframe %d: %s | %s ms", frame.keyframe(),
                                            frame_text(frame), timings_text(frame.timings())));
      });
  if (!status.ok()) return status;
  if (ffmpeg) {
    if (absl::Status video = encode_video(*ffmpeg, options); !video.ok()) return video;
    s.report_end(out, {{"video", options.video.string()}},
                 absl::StrFormat("wrote        %s\n", options.video.string()));
  } else {
    s.report_end(out, {}, "");
  }
  return absl::OkStatus();
}

}  // namespace caustica::client
