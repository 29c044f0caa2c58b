// The commands that are one unary call each: scene upload | list | info | delete, and stats.
#include <functional>
#include <iostream>

#include "client/commands.h"
#include "client/result_output.h"

namespace caustica::client {
namespace {

using Stub = v1::RenderService::Stub;

// Connects, makes the call and prints the response: as JSON, or with `print_text`.
template <typename Request, typename Response>
absl::Status unary_command(const GlobalOptions& global,
                           grpc::Status (Stub::*method)(grpc::ClientContext*, const Request&,
                                                        Response*),
                           const Request& request, std::ostream& out,
                           const std::function<void(const Response&)>& print_text) {
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(global.connect);
  if (!connection.ok()) return connection.status();
  absl::StatusOr<Response> response = (*connection)->call(method, request);
  if (!response.ok()) return response.status();
  if (global.json) {
    print_json(out, to_json(*response));
  } else {
    print_text(*response);
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status run_scene_upload(const GlobalOptions& global, const SceneUploadOptions& options,
                              std::ostream& out) {
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(global.connect);
  if (!connection.ok()) return connection.status();
  SceneOverrides overrides;
  overrides.structure = options.structure;
  absl::StatusOr<UploadedFile> uploaded =
      upload_scene_file(**connection, options.file, options.name, overrides, global.progress);
  if (!uploaded.ok()) return uploaded.status();
  if ((*connection)->embedded()) {
    const std::filesystem::path kept = (*connection)->embedded_data_dir();
    if (kept.empty()) {
      std::cerr << "caustica: scene upload: note: the scene lived on an embedded server that "
                   "stops with this command, without a data directory (--data-dir); start "
                   "caustica-server and pass --server to keep scenes\n";
    } else {
      std::cerr << "caustica: scene upload: kept in " << kept.string()
                << "; later commands without --server find it there\n";
    }
  }
  if (global.json) {
    print_json(out, to_json(uploaded->info));
  } else {
    out << uploaded->info.scene_id() << "\n";
  }
  return absl::OkStatus();
}

absl::Status run_scene_list(const GlobalOptions& global, std::ostream& out) {
  return unary_command<v1::ListScenesRequest, v1::ListScenesResponse>(
      global, &Stub::ListScenes, {}, out,
      [&](const v1::ListScenesResponse& list) { print_scene_table(out, list.scenes()); });
}

absl::Status run_scene_info(const GlobalOptions& global, const std::string& scene_id,
                            std::ostream& out) {
  v1::GetSceneRequest request;
  request.set_scene_id(scene_id);
  return unary_command<v1::GetSceneRequest, v1::SceneInfo>(
      global, &Stub::GetScene, request, out,
      [&](const v1::SceneInfo& info) { print_scene_info(out, info); });
}

absl::Status run_scene_delete(const GlobalOptions& global, const std::string& scene_id,
                              std::ostream& out) {
  v1::DeleteSceneRequest request;
  request.set_scene_id(scene_id);
  return unary_command<v1::DeleteSceneRequest, v1::DeleteSceneResponse>(
      global, &Stub::DeleteScene, request, out, [&](const v1::DeleteSceneResponse& response) {
        out << "deleted " << scene_id << ", freed " << mib_text(response.bytes_freed()) << "\n";
      });
}

absl::Status run_stats(const GlobalOptions& global, const std::string& scene_id,
                       std::ostream& out) {
  v1::GetStatsRequest request;
  request.set_scene_id(scene_id);
  return unary_command<v1::GetStatsRequest, v1::Stats>(
      global, &Stub::GetStats, request, out,
      [&](const v1::Stats& stats) { print_stats(out, stats); });
}

}  // namespace caustica::client
