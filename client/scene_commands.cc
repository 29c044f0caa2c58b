// The commands that are one unary call each: scene upload | list | info | delete, and stats.
#include <functional>
#include <iostream>

#include "client/commands.h"
#include "client/result_output.h"
#include "client/rpc_status.h"

namespace caustica::client {
namespace {

using Stub = v1::RenderService::Stub;

// Connects, makes the call and prints the response: as JSON, or with `print_text`.
template <typename Request, typename Response>
absl::Status unary_command(const GlobalOptions& global,
                           grpc::Status (Stub::*method)(grpc::ClientContext*, const Request&,
                                                        Response*),
                           const Request& request, std::ostream& out,
                           const std::function<void(const Response&)>& print_text,
                           const std::string& scene_id = "") {
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(global.connect);
  if (!connection.ok()) return connection.status();
  // A call about one scene goes to the replica that holds it.
  if (!scene_id.empty()) {
    if (absl::Status pinned = (*connection)->pin_to_scene(scene_id); !pinned.ok()) return pinned;
  }
  absl::StatusOr<Response> response = (*connection)->call(method, request);
  if (!response.ok()) return response.status();
  if (global.json) {
    print_json(out, to_json(*response));
  } else {
    print_text(*response);
  }
  return absl::OkStatus();
}

bool is_replicated_server(const std::string& server) {
  return server.starts_with("dns:") || server.find(',') != std::string::npos;
}

// scene list over replicas: every replica's scenes in one table, since round-robin would show
// one replica's alone. Replicas that do not answer are named on stderr.
absl::Status list_replicas(const GlobalOptions& global, std::ostream& out) {
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(global.connect);
  if (!connection.ok()) return connection.status();
  v1::ListScenesResponse all;
  int answered = 0;
  absl::Status last_error;
  for (const std::string& replica : (*connection)->replicas()) {
    std::unique_ptr<v1::RenderService::Stub> stub =
        v1::RenderService::NewStub((*connection)->replica_channel(replica));
    std::unique_ptr<grpc::ClientContext> context = (*connection)->new_context();
    v1::ListScenesResponse response;
    const grpc::Status status = stub->ListScenes(context.get(), {}, &response);
    if (!status.ok()) {
      last_error = to_absl(status);
      std::cerr << "caustica: scene list: " << replica << ": " << status.error_message() << "\n";
      continue;
    }
    ++answered;
    for (v1::SceneInfo& info : *response.mutable_scenes()) *all.add_scenes() = std::move(info);
  }
  if (answered == 0) return last_error;
  if (global.json) {
    print_json(out, to_json(all));
  } else {
    print_scene_table(out, all.scenes());
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status run_scene_upload(const GlobalOptions& global, const SceneUploadOptions& options,
                              std::ostream& out) {
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(global.connect);
  if (!connection.ok()) return connection.status();
  // With replicas: one picked at random among those serving, so that one-shot commands, each
  // with a channel of its own, still spread their scenes.
  if (absl::Status pinned = (*connection)->pin_any(); !pinned.ok()) return pinned;
  SceneOverrides overrides;
  overrides.structure = options.structure;
  overrides.structure_options = options.structure_options;
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
  if (is_replicated_server(global.connect.server)) return list_replicas(global, out);
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
      [&](const v1::SceneInfo& info) { print_scene_info(out, info); }, scene_id);
}

absl::Status run_scene_delete(const GlobalOptions& global, const std::string& scene_id,
                              std::ostream& out) {
  v1::DeleteSceneRequest request;
  request.set_scene_id(scene_id);
  return unary_command<v1::DeleteSceneRequest, v1::DeleteSceneResponse>(
      global, &Stub::DeleteScene, request, out,
      [&](const v1::DeleteSceneResponse& response) {
        out << "deleted " << scene_id << ", freed " << mib_text(response.bytes_freed()) << "\n";
      },
      scene_id);
}

absl::Status run_stats(const GlobalOptions& global, const std::string& scene_id,
                       std::ostream& out) {
  v1::GetStatsRequest request;
  request.set_scene_id(scene_id);
  return unary_command<v1::GetStatsRequest, v1::Stats>(
      global, &Stub::GetStats, request, out,
      [&](const v1::Stats& stats) { print_stats(out, stats); }, scene_id);
}

}  // namespace caustica::client
