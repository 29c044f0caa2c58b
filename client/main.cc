// caustica: the command-line client of the Caustica render server. Parses flags and calls the
// command functions of client/commands.h, which do the work (and which tests call directly).
#include <CLI/CLI.hpp>
#include <functional>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "client/commands.h"
#include "client/frame_image.h"
#include "client/progress_bar.h"
#include "client/rpc_status.h"
#include "proto/wire/api_version.h"
#include "proto/wire/frame_heap.h"
#include "renderer/accel/structure_kind.h"
#include "tools/cli/setting_names.h"
#include "tools/cli/structure_option.h"

namespace {

using namespace caustica::client;

// --structure NAME, which sets `structure`; `effect` says what it changes.
void add_structure_option(CLI::App* command, std::optional<caustica::StructureKind>& structure,
                          const std::string& effect) {
  command
      ->add_option(
          "--structure", structure,
          "ray-tracing structure: " + caustica::structure_kind_list() + " (" + effect + ")")
      ->type_name("NAME")
      ->transform(caustica::structure_names());
}

// --structure-option NAME=VALUE, repeatable, into `options`; `effect` says what it changes.
void add_structure_options(CLI::App* command, std::vector<std::string>& options,
                           const std::string& effect) {
  command
      ->add_option("--structure-option", options,
                   std::string(caustica::kStructureOptionHelp) + " (" + effect + ")")
      ->type_name("NAME=VALUE")
      ->check(caustica::structure_option_check());
}

// The flags that change a scene: resolution, photons, structure and estimators.
void add_scene_overrides(CLI::App* command, SceneOverrides& o) {
  command->add_option("--width", o.width, "image width in pixels (changes the scene)");
  command->add_option("--height", o.height, "image height in pixels (changes the scene)");
  command->add_option("--photons", o.photons, "photons emitted per pass (changes the scene)");
  command->add_option("--k", o.k, "photons per radiance estimate (changes the scene)");
  add_structure_option(command, o.structure, "changes the scene");
  add_structure_options(command, o.structure_options, "changes the scene");
  command
      ->add_option("--integrator", o.integrator,
                   "photon or path, the unbiased path-traced reference (changes the scene)")
      ->type_name("NAME")
      ->transform(caustica::integrator_names());
  command
      ->add_option("--estimator", o.estimator,
                   "knn, sppm or vkde, the photon integrator's density estimator (changes the "
                   "scene)")
      ->type_name("NAME")
      ->transform(caustica::estimator_names());
  command
      ->add_option("--final-gather", o.final_gather,
                   "true or false: the knn estimator's indirect light by final gathering (changes "
                   "the scene)")
      ->type_name("BOOL");
}

// SCENE, --keep, --exposure and the scene overrides of render, stream and animate.
void add_frame_job(CLI::App* command, FrameJobOptions& job) {
  command->add_option("scene", job.scene, "scene id, or a scene file to upload for this command")
      ->required();
  command->add_flag("--keep", job.keep, "keep a scene uploaded from a file on the server");
  command->add_option("--exposure", job.exposure_stops, "exposure in stops (8-bit files)");
  add_scene_overrides(command, job.overrides);
}

// Refuses an image file name the CLI cannot write before anything is uploaded; `prefix` turns a
// --format value into a file name.
CLI::Validator frame_file_check(const std::string& prefix) {
  return CLI::Validator(
      [prefix](std::string& value) -> std::string {
        absl::StatusOr<caustica::v1::FrameFormat> format = frame_format_for(prefix + value, 0);
        return format.ok() ? std::string() : std::string(format.status().message());
      },
      "", "FILE");
}

// -o DIR and --format of the commands that write numbered frames.
void add_frame_files(CLI::App* command, std::filesystem::path& directory, std::string& format) {
  command->add_option("-o,--output", directory, "output directory")->required();
  command->add_option("--format", format, "frame files: png, jpg, exr or pfm")
      ->check(frame_file_check("frame."));
}

}  // namespace

int main(int argc, char** argv) {
  caustica::wire::keep_frame_buffers();
  CLI::App app{
      "Caustica client: upload scenes, change lights and fetch photon-mapped frames "
      "from a caustica-server (without --server: localhost:50051, else a local server "
      "started for the command)."};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("caustica ") + caustica::wire::release_version() +
                                        " (API " + caustica::wire::api_version() + ")");
  app.option_defaults()->always_capture_default();  // --help shows the defaults
  app.fallthrough();                                // global flags may follow the subcommand
  GlobalOptions global;
  app.add_option("--server", global.connect.server,
                 "server address HOST:PORT; replicas as HOST:PORT,HOST:PORT,... or "
                 "dns:///NAME:PORT (stateless calls round-robin, scene calls go to the replica "
                 "that holds the scene)");
  app.add_option("--timeout", global.connect.timeout_s, "deadline of every call in seconds")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-message-mb", global.connect.max_message_mb,
                 "largest message accepted from the server")
      ->check(CLI::PositiveNumber);
  app.add_option("--token", global.connect.token,
                 "bearer token for a server started with --tokens, sent as 'authorization: "
                 "Bearer TOKEN' with every call; prefer $CAUSTICA_TOKEN, since other users can "
                 "see command lines")
      ->envname("CAUSTICA_TOKEN")
      ->type_name("TOKEN");
  app.add_option("--tls-ca", global.connect.tls_ca,
                 "connect with TLS, verifying the server's certificate against these PEM CA "
                 "certificates")
      ->check(CLI::ExistingFile.description(""))
      ->type_name("FILE");
  CLI::Option* tls_cert =
      app.add_option("--tls-cert", global.connect.tls_cert,
                     "PEM client certificate for a server that requires one (mutual TLS; with "
                     "--tls-key); connects with TLS, against gRPC's default roots without --tls-ca")
          ->check(CLI::ExistingFile.description(""))
          ->type_name("FILE");
  CLI::Option* tls_key =
      app.add_option("--tls-key", global.connect.tls_key, "PEM private key of --tls-cert")
          ->check(CLI::ExistingFile.description(""))
          ->type_name("FILE");
  tls_cert->needs(tls_key);
  tls_key->needs(tls_cert);
  std::optional<std::string> data_dir;
  app.add_option("--data-dir", data_dir,
                 "where the embedded server (no --server) keeps scenes between commands; '' "
                 "keeps none. Default: $CAUSTICA_DATA_DIR, else $XDG_STATE_HOME/caustica, else "
                 "~/.local/state/caustica")
      ->type_name("DIR");
  app.add_flag("--json", global.json, "print each result as one JSON object");

  // Every subcommand's callback stores what to run; it runs after parsing succeeded.
  std::string command_name;
  std::function<absl::Status()> action;
  std::function<int()> exit_code_action;
  const auto on = [&](CLI::App* command, std::string name, std::function<absl::Status()> run) {
    command->callback([&, name, run] {
      command_name = name;
      action = run;
    });
  };

  CLI::App* scene = app.add_subcommand("scene", "upload, list, inspect and delete scenes");
  scene->require_subcommand(1);
  SceneUploadOptions upload;
  CLI::App* upload_cmd = scene->add_subcommand("upload", "upload a scene file; prints its id");
  upload_cmd->add_option("file", upload.file, "scene file (JSON)")->required();
  upload_cmd->add_option("--name", upload.name, "name shown by scene list");
  add_structure_option(upload_cmd, upload.structure, "replaces the file's settings.structure");
  add_structure_options(upload_cmd, upload.structure_options, "over the file's settings.build");
  on(upload_cmd, "scene upload", [&] { return run_scene_upload(global, upload, std::cout); });
  on(scene->add_subcommand("list", "list the scenes on the server"), "scene list",
     [&] { return run_scene_list(global, std::cout); });
  std::string scene_id;
  CLI::App* info_cmd = scene->add_subcommand("info", "show one scene");
  info_cmd->add_option("id", scene_id, "scene id")->required();
  on(info_cmd, "scene info", [&] { return run_scene_info(global, scene_id, std::cout); });
  CLI::App* delete_cmd = scene->add_subcommand("delete", "delete a scene");
  delete_cmd->add_option("id", scene_id, "scene id")->required();
  on(delete_cmd, "scene delete", [&] { return run_scene_delete(global, scene_id, std::cout); });

  CLI::App* light = app.add_subcommand("light", "change a scene's lights");
  light->require_subcommand(1);
  LightSetOptions lights;
  CLI::App* set_cmd = light->add_subcommand(
      "set", "replace the lights (emissive triangles stay) and print what was rebuilt");
  set_cmd->add_option("scene", lights.scene, "scene id")->required();
  set_cmd->add_option("--point", lights.point, "a point light at X,Y,Z");
  set_cmd->add_option("--spot", lights.spot, "a spot light at X,Y,Z (with --direction)");
  set_cmd->add_option("--directional", lights.directional,
                      "a directional light travelling along DX,DY,DZ");
  set_cmd->add_option("--direction", lights.direction, "spot axis DX,DY,DZ");
  set_cmd->add_option("--intensity", lights.intensity,
                      "R,G,B or one value: W/sr (point, spot) or W/m^2 (directional)");
  set_cmd->add_option("--inner", lights.inner_angle, "spot: full intensity inside (degrees)");
  set_cmd->add_option("--outer", lights.outer_angle, "spot: nothing outside (degrees)");
  set_cmd->add_option("--name", lights.name, "light name");
  set_cmd->add_option("--file", lights.file, "lights file: {\"lights\": [...]} as in scene files");
  set_cmd->add_flag("--none", lights.none, "no lights besides the emissive triangles");
  set_cmd->add_option("--expect-epoch", lights.expect_epoch,
                      "apply only if the scene's lights epoch is still N");
  on(set_cmd, "light set", [&] { return run_light_set(global, lights, std::cout); });

  LightEmitOptions emit;
  CLI::App* emit_cmd = light->add_subcommand(
      "emit",
      "change an emissive material's emission (its triangles are area lights); the other lights "
      "stay");
  emit_cmd->add_option("scene", emit.scene, "scene id")->required();
  emit_cmd->add_option("material", emit.material, "the emissive material's name")->required();
  emit_cmd->add_option("--radiance", emit.radiance, "R,G,B or one value: the new radiance");
  emit_cmd->add_flag("--on", emit.on, "emit again (at the radiance it keeps)");
  emit_cmd->add_flag("--off", emit.off, "emit nothing, keeping the radiance for --on");
  emit_cmd->add_option("--expect-epoch", emit.expect_epoch,
                       "apply only if the scene's lights epoch is still N");
  on(emit_cmd, "light emit", [&] { return run_light_emit(global, emit, std::cout); });

  LightEnvironmentOptions environment;
  CLI::App* environment_cmd = light->add_subcommand(
      "environment", "change the environment's intensity or rotation; the other lights stay");
  environment_cmd->add_option("scene", environment.scene, "scene id")->required();
  environment_cmd->add_option("--intensity", environment.intensity,
                              "the factor its map's radiance is scaled by");
  environment_cmd->add_option("--rotation", environment.rotation,
                              "degrees its map is turned about the up axis (+y)");
  environment_cmd->add_option("--expect-epoch", environment.expect_epoch,
                              "apply only if the scene's lights epoch is still N");
  on(environment_cmd, "light environment",
     [&] { return run_light_environment(global, environment, std::cout); });

  CLI::App* mesh = app.add_subcommand("mesh", "move and reshape a scene's meshes");
  mesh->require_subcommand(1);
  MeshMoveOptions move;
  CLI::App* move_cmd = mesh->add_subcommand(
      "move",
      "place a mesh as uploaded by a transform (scale, rotate, translate) and print what was "
      "rebuilt");
  move_cmd->add_option("scene", move.scene, "scene id")->required();
  move_cmd->add_option("mesh", move.mesh, "the mesh's name, as scene info lists it")->required();
  move_cmd->add_option("--translate", move.translate, "X,Y,Z");
  move_cmd->add_option("--rotate", move.rotate, "X,Y,Z degrees about x, then y, then z");
  move_cmd->add_option("--scale", move.scale, "X,Y,Z or one value");
  move_cmd->add_option("--expect-epoch", move.expect_epoch,
                       "apply only if the scene's geometry epoch is still N");
  on(move_cmd, "mesh move", [&] { return run_mesh_move(global, move, std::cout); });
  MeshReshapeOptions reshape;
  CLI::App* reshape_cmd = mesh->add_subcommand(
      "reshape",
      "replace a mesh's vertices (and normals) by those of a model file's one mesh, streamed in "
      "chunks, and print what was rebuilt");
  reshape_cmd->add_option("scene", reshape.scene, "scene id")->required();
  reshape_cmd->add_option("mesh", reshape.mesh, "the mesh's name, as scene info lists it")
      ->required();
  reshape_cmd
      ->add_option("--from", reshape.file,
                   "a model file (OBJ, PLY, glTF, ...) of one mesh with as many vertices, "
                   "in the same order")
      ->required();
  reshape_cmd->add_option("--expect-epoch", reshape.expect_epoch,
                          "apply only if the scene's geometry epoch is still N");
  on(reshape_cmd, "mesh reshape", [&] { return run_mesh_reshape(global, reshape, std::cout); });

  RenderOptions render;
  CLI::App* render_cmd = app.add_subcommand("render", "render one image");
  add_frame_job(render_cmd, render.job);
  render_cmd
      ->add_option("-o,--output", render.output,
                   "image: .png/.jpg (sRGB, exposed) or .exr/.pfm (linear)")
      ->required()
      ->check(frame_file_check(""));
  render_cmd->add_option("--passes", render.passes, "passes (default: the scene file's, or 1)");
  on(render_cmd, "render", [&] { return run_render(global, render, std::cout); });

  StreamOptions stream;
  CLI::App* stream_cmd =
      app.add_subcommand("stream", "write DIR/frame_0000.png ... as the image refines");
  add_frame_job(stream_cmd, stream.job);
  stream_cmd->add_option("-o,--output", stream.directory, "output directory");
  stream_cmd->add_option("--format", stream.format, "frame files: png, jpg, exr or pfm")
      ->check(frame_file_check("frame."));
  stream_cmd->add_option("--tev", stream.tev,
                         "also show each frame in the tev viewer listening at HOST:PORT "
                         "(127.0.0.1:14158 by default there)");
  stream_cmd->add_option("--passes", stream.passes, "passes in the last frame");
  stream_cmd->add_option("--every", stream.every, "passes between frames")
      ->check(CLI::PositiveNumber);
  on(stream_cmd, "stream", [&] { return run_stream(global, stream, std::cout); });

  ViewOptions view;
  CLI::App* view_cmd = app.add_subcommand(
      "view",
      "open the scene in the server's browser viewer (drag lights, orbit the camera); without "
      "--server, a server started for the command serves it until Ctrl-C");
  view_cmd->add_option("scene", view.scene, "scene id, or a scene file to upload")->required();
  view_cmd->add_flag("--keep", view.keep,
                     "keep a file uploaded to the command's own server (one on --server stays)");
  view_cmd->add_flag("!--no-open", view.open, "print the URL only; do not start a browser");
  add_scene_overrides(view_cmd, view.overrides);
  on(view_cmd, "view", [&] { return run_view(global, view, std::cout); });

  AnimateOptions animate;
  CLI::App* animate_cmd = app.add_subcommand(
      "animate",
      "play a keyframed script (lights, camera, emitters, meshes) or a glTF animation; one "
      "image per keyframe");
  add_frame_job(animate_cmd, animate.job);
  add_frame_files(animate_cmd, animate.directory, animate.format);
  animate_cmd->add_option("--script", animate.script,
                          "{\"keyframes\": [{\"lights\": [...], \"camera\": {...}, \"emitters\": "
                          "[...], \"environment\": {...}, \"meshes\": [{\"mesh\": NAME, "
                          "\"transform\": {...}}], \"passes\": N}, ...]} (docs/server.md)");
  animate_cmd->add_option("--gltf-animation", animate.gltf_animation,
                          "play the glTF animation of this name (or number, \"0\" the first) of "
                          "the scene file's models, sampled at --fps; with --script, frame i "
                          "is keyframe i");
  animate_cmd->add_option("--video", animate.video, "also join the frames into a video (ffmpeg)");
  animate_cmd
      ->add_option("--fps", animate.fps,
                   "frames a second: the video's, and the glTF animation's sampling")
      ->check(CLI::PositiveNumber);
  animate_cmd
      ->add_option("--servers", animate.servers,
                   "replicas HOST:PORT,... that share the keyframes (instead of --server): the "
                   "scene file goes to each, a failed replica's keyframe goes to another, and one "
                   "that is down is retried until it answers")
      ->delimiter(',')
      ->type_name("LIST");
  on(animate_cmd, "animate", [&] { return run_animate(global, animate, std::cout); });

  std::string stats_scene;
  CLI::App* stats_cmd = app.add_subcommand("stats", "server, device, memory, latencies, scenes");
  stats_cmd->add_option("--scene", stats_scene, "limit the per-scene part to this scene");
  on(stats_cmd, "stats", [&] { return run_stats(global, stats_scene, std::cout); });

  SmokeOptions smoke;
  CLI::App* smoke_cmd = app.add_subcommand(
      "smoke", "upload a small Cornell box, change its lights, check the frames (exit 0 or 1)");
  smoke_cmd->add_option("--scene", smoke.scene, "scene file (default: the bundled cornell-box)");
  smoke_cmd->add_option("--size", smoke.size, "image width and height")->check(CLI::PositiveNumber);
  smoke_cmd->add_option("--photons", smoke.photons, "photons per pass")->check(CLI::PositiveNumber);
  smoke_cmd->callback(
      [&] { exit_code_action = [&] { return run_smoke(global, smoke, std::cout); }; });

  CLI11_PARSE(app, argc, argv);
  global.progress = stderr_is_terminal();
  if (data_dir) global.connect.embedded.data_dir = std::filesystem::path(*data_dir);
  if (exit_code_action) return exit_code_action();
  if (const absl::Status status = action(); !status.ok()) {
    std::cerr << error_line(command_name, status) << "\n";
    return 1;
  }
  return 0;
}
