// glTF 2.0 scenes (.gltf with external or embedded buffers, and binary .glb), read through
// tinygltf. Takes every TRIANGLES primitive reachable from the default scene's node hierarchy
// with the node transforms applied, the materials they use (pbrMetallicRoughness,
// KHR_materials_transmission, KHR_materials_ior, KHR_materials_emissive_strength) and
// KHR_lights_punctual lights. Textures, cameras, skins and animation are ignored.
#pragma once

#include <filesystem>

#include "absl/status/statusor.h"
#include "renderer/scene/mesh_file.h"

namespace caustica {

// One Mesh per (node, primitive) pair; primitives without a material get kNoMaterial.
absl::StatusOr<MeshFile> load_gltf(const std::filesystem::path& path);

}  // namespace caustica
