#include "renderer/scene/load_scene.h"

#include <string>

#include "absl/strings/string_view.h"
#include "renderer/scene/file_io.h"
#include "renderer/scene/mesh_file.h"
#include "renderer/scene/mesh_scene.h"
#include "renderer/scene/scene_json.h"
#include "renderer/scene/status_util.h"
#include "renderer/scene/validate.h"

namespace caustica {

absl::StatusOr<Scene> load_scene(const std::filesystem::path& path,
                                 std::vector<std::string>* warnings) {
  if (is_mesh_file_name(path)) return load_mesh_scene(path, warnings);
  SCENE_ASSIGN_OR_RETURN(const std::string text, read_file(path));
  return parse_scene(text, path.parent_path(), path.string(), warnings);
}

absl::StatusOr<Scene> parse_scene(std::string_view json_text, const std::filesystem::path& base_dir,
                                  std::string_view source_name,
                                  std::vector<std::string>* warnings) {
  // Debian's abseil has its own string_view type; the public API speaks std::string_view.
  const absl::string_view text(json_text.data(), json_text.size());
  const absl::string_view source(source_name.data(), source_name.size());
  SCENE_ASSIGN_OR_RETURN(Scene scene, scene_from_json(text, base_dir, source, warnings));
  SCENE_RETURN_IF_ERROR(annotate(validate_scene(scene), source));
  return scene;
}

}  // namespace caustica
