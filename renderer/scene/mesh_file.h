// Mesh files (OBJ, PLY, glTF): what one file contributes to a scene, and the dispatch on its
// extension. The scene reader places the result and merges its materials and lights.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "absl/status/statusor.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Marks triangles whose file gave them no material; the scene must supply one.
inline constexpr uint32_t kNoMaterial = 0xffffffffu;

struct MeshFile {
  std::vector<Mesh> meshes;         // material_ids index `materials` or are kNoMaterial
  std::vector<Material> materials;  // empty for formats without materials (PLY)
  std::vector<Light> lights;        // glTF KHR_lights_punctual, already in file space
};

// Loads .obj (+ .mtl), .ply, .ply.gz, .gltf or .glb, chosen by the file name's extension
// (case-insensitive). NotFoundError for a missing file; every error names the file.
absl::StatusOr<MeshFile> load_mesh_file(const std::filesystem::path& path);

}  // namespace caustica
