// The SCENE argument of render, stream and animate: the id of a scene on the server, or a scene
// file, which is then uploaded for the one command and deleted after it (unless kept). Flags that
// override resolution, photon settings and the structure go into the file's scene before upload,
// or to a scene id through UpdateSettings.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"
#include "client/connection.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/scene/scene.h"

namespace caustica::client {

struct SceneOverrides {
  std::optional<uint32_t> width, height, photons, k;
  std::optional<StructureKind> structure;
  std::optional<Integrator> integrator;
  std::optional<EstimatorKind> estimator;
  std::optional<bool> final_gather;
  // --structure-option NAME=VALUE, as given and already checked (tools/cli/structure_option.h).
  std::vector<std::string> structure_options;

  bool empty() const {
    return !width && !height && !photons && !k && !structure && !integrator && !estimator &&
           !final_gather && structure_options.empty();
  }
  void apply(Scene& scene) const;
  v1::UpdateSettingsRequest request(const std::string& scene_id) const;
};

// True when `arg` names a file rather than a scene id: it exists, or it looks like a path.
bool is_scene_file(const std::string& arg);

// The name a scene file gets on the server: its stem, or its directory's name for "scene.json"
// (scenes/cornell-box/scene.json -> "cornell-box").
std::string default_scene_name(const std::filesystem::path& file);

struct UploadedFile {
  v1::SceneInfo info;
  uint32_t passes = 1;  // the file's settings.passes (SceneInfo does not carry it)
};

// A scene file, or a bare model file framed as a scene, with the loader's warnings on stderr.
absl::StatusOr<Scene> load_scene_file(const std::filesystem::path& file);

// Loads `file`, applies `overrides`, and uploads it with a progress bar when `progress`.
absl::StatusOr<UploadedFile> upload_scene_file(Connection& connection,
                                               const std::filesystem::path& file,
                                               const std::string& name,
                                               const SceneOverrides& overrides, bool progress);

class SceneSource {
 public:
  static absl::StatusOr<std::unique_ptr<SceneSource>> open(Connection& connection,
                                                           const std::string& arg,
                                                           const SceneOverrides& overrides,
                                                           bool keep, bool progress);
  ~SceneSource();  // deletes an uploaded scene unless kept
  SceneSource(const SceneSource&) = delete;
  SceneSource& operator=(const SceneSource&) = delete;

  const std::string& id() const { return id_; }
  // The passes a scene file asks for; nullopt for a scene id.
  std::optional<uint32_t> file_passes() const { return file_passes_; }
  const std::optional<v1::SceneInfo>& uploaded() const { return uploaded_; }
  // What UpdateSettings rebuilt when overrides were applied to a scene id.
  const std::optional<v1::RebuildReport>& settings_report() const { return settings_report_; }

 private:
  explicit SceneSource(Connection& connection) : connection_(connection) {}

  Connection& connection_;
  std::string id_;
  bool delete_at_end_ = false;
  std::optional<uint32_t> file_passes_;
  std::optional<v1::SceneInfo> uploaded_;
  std::optional<v1::RebuildReport> settings_report_;
};

}  // namespace caustica::client
