// Mesh files (OBJ, PLY, glTF, and the formats Assimp reads): what one file contributes to a scene,
// and the dispatch on its extension. The scene reader places the result and merges its materials
// and lights; a bare mesh file becomes a whole scene through mesh_scene.h.
#pragma once

#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Marks triangles whose file gave them no material; the scene must supply one.
inline constexpr uint32_t kNoMaterial = 0xffffffffu;

// The maps of a model file's materials that no material model reads, gathered by kind in the
// order first noted, so that a model that looks flatter than its author made it says why: one
// warning per kind, naming the files and counting the materials.
class UnreadMaps {
 public:
  void note(std::string_view kind, const std::string& file);
  // "NAME: its KIND maps are not read (N materials): a.png, b.png", one per kind.
  void warn(const std::string& file_name, std::vector<std::string>& warnings) const;

 private:
  struct Kind {
    std::string name;
    std::set<std::string> files;
    size_t materials = 0;
  };
  std::vector<Kind> kinds_;
};

struct MeshFile {
  std::vector<Mesh> meshes;         // material_ids index `materials` or are kNoMaterial
  std::vector<Material> materials;  // empty for formats without materials (PLY)
  std::vector<TextureImage> textures;  // what the materials' maps index
  // Media the meshes enclose (their interior_medium indexes these): glTF's
  // KHR_materials_volume, in file space.
  std::vector<Medium> media;
  std::vector<Light> lights;        // glTF KHR_lights_punctual, already in file space
  // Perspective cameras of the file (glTF), already in file space; a JSON scene ignores them, a
  // bare mesh file renders through the first.
  std::vector<Camera> cameras;
  // What the loader skipped or approximated, one sentence each naming the file, for the user.
  std::vector<std::string> warnings;
};

// A model file's Phong material whose color + specular (kd + ks) exceeds 1 in a channel would
// reflect more light than it receives: both are scaled by one factor, which keeps their hues and
// their balance, so that the worst channel sums to 1 as validation adds them. Returns the factor,
// 1 when nothing was scaled.
float conserve_phong_energy(Material* material);

// Loads .obj (+ .mtl), .ply, .ply.gz, .gltf or .glb with the own loaders and every other extension
// Assimp imports (.fbx, .dae, .stl, .3mf, .off, .3ds, ...) through mesh_assimp.h, chosen by the
// file name's extension (case-insensitive). NotFoundError for a missing file; every error names
// the file.
absl::StatusOr<MeshFile> load_mesh_file(const std::filesystem::path& path);

// Whether load_mesh_file reads files with this name's extension; false for .json and unknown ones.
bool is_mesh_file_name(const std::filesystem::path& path);

}  // namespace caustica
