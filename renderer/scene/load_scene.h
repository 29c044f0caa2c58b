// Entry points for scene files: the JSON format of docs/scene-format.md, the mesh files it
// references, and validate_scene on the result. A bare model file is a scene too (mesh_scene.h).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Loads a JSON scene file and every mesh it references; validates the result. A file whose
// extension is a mesh format (.obj, .ply, .gltf, .glb, .fbx, .stl, ...) is loaded as a bare model
// with a generated camera, floor and light (load_mesh_scene). The loaders' warnings (a scene
// file's: of each mesh file it references) go to `warnings` when given.
absl::StatusOr<Scene> load_scene(const std::filesystem::path& path,
                                 std::vector<std::string>* warnings = nullptr);

// Same from text already in memory; relative mesh paths resolve against base_dir; source_name
// names the text in errors.
absl::StatusOr<Scene> parse_scene(std::string_view json_text, const std::filesystem::path& base_dir,
                                  std::string_view source_name,
                                  std::vector<std::string>* warnings = nullptr);

}  // namespace caustica
