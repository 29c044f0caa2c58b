// Entry points for scene files: the JSON format of docs/scene-format.md, the mesh files it
// references, and validate_scene on the result.
#pragma once

#include <filesystem>
#include <string_view>

#include "absl/status/statusor.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Loads a JSON scene file and every mesh it references; validates the result.
absl::StatusOr<Scene> load_scene(const std::filesystem::path& path);

// Same from text already in memory; relative mesh paths resolve against base_dir; source_name
// names the text in errors.
absl::StatusOr<Scene> parse_scene(std::string_view json_text, const std::filesystem::path& base_dir,
                                  std::string_view source_name);

}  // namespace caustica
