// The JSON scene format of docs/scene-format.md, read into a Scene. Mesh files named by the
// scene are loaded and placed here; checks that need the whole scene are validate_scene's job.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Errors start with `source_name` and then give line:column for JSON syntax errors or the JSON
// path of the field (e.g. "shapes[3].vertices[2]") for everything else. Relative mesh paths
// resolve against `base_dir`. What the mesh files' loaders warn of goes to `warnings` when given,
// each after the source and the field of the shape that names the file.
absl::StatusOr<Scene> scene_from_json(absl::string_view json_text,
                                      const std::filesystem::path& base_dir,
                                      absl::string_view source_name,
                                      std::vector<std::string>* warnings = nullptr);

// What a scene file's meshes are named: the shape's path, the name the scene gives it and the
// file's name for the part, "shapes[2] 'dragon' (body)"; the last two where there are such.
std::string shape_label(absl::string_view path, absl::string_view scene_name,
                        absl::string_view file_part);
// shape_label read back: "shapes[2]" and "dragon"; both empty for a name it did not write.
struct ShapeLabel {
  absl::string_view path, name;
};
ShapeLabel parse_shape_label(absl::string_view label);

}  // namespace caustica
