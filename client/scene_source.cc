// Scene ids and scene files on the command line (see scene_source.h).
#include "client/scene_source.h"

#include <chrono>
#include <iostream>
#include <string_view>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/progress_bar.h"
#include "client/scene_upload.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/load_scene.h"

namespace caustica::client {
namespace {

constexpr auto kCleanupTimeout = std::chrono::seconds(60);

}  // namespace

void SceneOverrides::apply(Scene& scene) const {
  if (width) scene.camera.width = static_cast<int>(*width);
  if (height) scene.camera.height = static_cast<int>(*height);
  if (photons) scene.settings.photons_per_pass = *photons;
  if (k) scene.settings.k_nearest = *k;
  if (structure) scene.settings.structure = *structure;
  if (integrator) scene.settings.integrator = *integrator;
  if (estimator) scene.settings.estimator = *estimator;
  if (final_gather) scene.settings.final_gather = *final_gather;
  scene.settings.build = apply_structure_options(structure_options, scene.settings.build);
}

v1::UpdateSettingsRequest SceneOverrides::request(const std::string& scene_id) const {
  v1::UpdateSettingsRequest request;
  request.set_scene_id(scene_id);
  if (width) request.set_width(*width);
  if (height) request.set_height(*height);
  if (photons) request.mutable_settings()->set_photons_per_pass(*photons);
  if (k) request.mutable_settings()->set_k_nearest(*k);
  if (structure) request.mutable_settings()->set_structure(wire::encode_structure(*structure));
  if (integrator) request.mutable_settings()->set_integrator(wire::encode_integrator(*integrator));
  if (estimator) request.mutable_settings()->set_estimator(wire::encode_estimator(*estimator));
  if (final_gather) request.mutable_settings()->set_final_gather(*final_gather);
  if (!structure_options.empty()) {
    // Only the fields the options name are set; the others keep the scene's.
    RenderSettings given;
    given.build = apply_structure_options(structure_options, given.build);
    const v1::BuildOptions all = wire::encode_settings(given).build();
    v1::BuildOptions& build = *request.mutable_settings()->mutable_build();
    for (const std::string& option : structure_options) {
      const std::string_view name = std::string_view(option).substr(0, option.find('='));
      if (name == "binned-sah-stages") {
        *build.mutable_binned_sah_stages() = all.binned_sah_stages();
      } else if (name == "binned-sah-reorder") {
        build.set_binned_sah_reorder(all.binned_sah_reorder());
      } else if (name == "kd-traversal") {
        build.set_kd_traversal(all.kd_traversal());
      } else if (name == "refit") {
        build.set_refit(all.refit());
      } else if (name == "refit-sah-bound") {
        build.set_refit_sah_bound(all.refit_sah_bound());
      }
    }
  }
  return request;
}

bool is_scene_file(const std::string& arg) {
  std::error_code error;
  if (std::filesystem::is_regular_file(arg, error)) return true;
  // Ids never contain a slash or end in .json; such an argument is a file that is missing, and
  // load_scene says so better than NOT_FOUND from the server would.
  return arg.find('/') != std::string::npos ||
         (arg.size() > 5 && arg.compare(arg.size() - 5, 5, ".json") == 0);
}

std::string default_scene_name(const std::filesystem::path& file) {
  const std::filesystem::path absolute = std::filesystem::absolute(file);
  if (absolute.stem() == "scene" && absolute.has_parent_path()) {
    return absolute.parent_path().filename().string();
  }
  return absolute.stem().string();
}

absl::StatusOr<Scene> load_scene_file(const std::filesystem::path& file) {
  std::vector<std::string> warnings;
  absl::StatusOr<Scene> scene = load_scene(file, &warnings);
  for (const std::string& warning : warnings) std::cerr << "caustica: warning: " << warning << "\n";
  return scene;
}

absl::StatusOr<UploadedFile> upload_scene_file(Connection& connection,
                                               const std::filesystem::path& file,
                                               const std::string& name,
                                               const SceneOverrides& overrides, bool progress) {
  absl::StatusOr<Scene> scene = load_scene_file(file);
  if (!scene.ok()) return scene.status();
  overrides.apply(*scene);
  UploadedFile uploaded;
  uploaded.passes = scene->settings.passes;
  ProgressBar bar("upload", progress);
  std::unique_ptr<grpc::ClientContext> context = connection.new_context();
  absl::StatusOr<v1::SceneInfo> info = upload_scene(
      connection.stub(), *context, *scene, name.empty() ? default_scene_name(file) : name,
      [&](uint64_t sent, uint64_t total) {
        bar.update(static_cast<double>(sent), static_cast<double>(total),
                   absl::StrFormat("%.1f of %.1f MiB", sent / 1048576.0, total / 1048576.0));
      });
  if (!info.ok()) return info.status();
  uploaded.info = *std::move(info);
  return uploaded;
}

absl::StatusOr<std::unique_ptr<SceneSource>> SceneSource::open(Connection& connection,
                                                               const std::string& arg,
                                                               const SceneOverrides& overrides,
                                                               bool keep, bool progress) {
  std::unique_ptr<SceneSource> source(new SceneSource(connection));
  // With replicas, the upload and every later call about the scene go to one of them.
  if (absl::Status pinned =
          is_scene_file(arg) ? connection.pin_any() : connection.pin_to_scene(arg);
      !pinned.ok()) {
    return pinned;
  }
  if (is_scene_file(arg)) {
    absl::StatusOr<UploadedFile> uploaded =
        upload_scene_file(connection, arg, "", overrides, progress);
    if (!uploaded.ok()) return uploaded.status();
    source->id_ = uploaded->info.scene_id();
    source->delete_at_end_ = !keep;
    source->file_passes_ = uploaded->passes;
    source->uploaded_ = std::move(uploaded->info);
    return source;
  }
  source->id_ = arg;
  if (!overrides.empty()) {
    absl::StatusOr<v1::RebuildReport> report =
        connection.call(&v1::RenderService::Stub::UpdateSettings, overrides.request(arg));
    if (!report.ok()) return report.status();
    source->settings_report_ = *std::move(report);
  }
  return source;
}

SceneSource::~SceneSource() {
  if (!delete_at_end_) return;
  // Best effort: the command's own result matters more than a failed cleanup, and a scene on an
  // embedded server goes away with it anyway.
  v1::DeleteSceneRequest request;
  request.set_scene_id(id_);
  // Its own deadline: a short --timeout that cut the command off must not also leave the scene
  // behind, and the delete may wait on the server for the cancelled render's current pass.
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + kCleanupTimeout);
  connection_.authorize(context);
  v1::DeleteSceneResponse response;
  connection_.stub().DeleteScene(&context, request, &response);
}

}  // namespace caustica::client
