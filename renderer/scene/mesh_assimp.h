// Mesh files in the formats the own loaders do not read (FBX, COLLADA, STL, 3MF, OFF, 3DS, ...),
// read through the Open Asset Import Library (Assimp). Polygons are triangulated and identical
// vertices joined; every mesh reachable from the root node becomes one Mesh per node that uses it,
// with the node hierarchy's transforms applied. Point and line meshes are skipped with a warning.
// Materials keep what our model can express (docs/scene-format.md, "Assimp formats"), cameras and
// point, spot and directional lights are read as glTF's are; skins and animations are ignored.
#pragma once

#include <filesystem>
#include <string_view>

#include "absl/status/statusor.h"
#include "renderer/scene/mesh_file.h"

namespace caustica {

// Triangles without a material in the file (Assimp gives every mesh one, often its default)
// carry the file's material anyway, so kNoMaterial does not occur. Errors name the file; Assimp's
// own failure message is kept after it.
absl::StatusOr<MeshFile> load_assimp(const std::filesystem::path& path);

// Whether Assimp has an importer for `extension` (with its dot, any case), e.g. ".fbx".
bool assimp_reads_extension(std::string_view extension);

}  // namespace caustica
