// glTF 2.0 scenes (.gltf with external or embedded buffers, and binary .glb), read through
// tinygltf. Takes every TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN primitive reachable from the
// default scene's node hierarchy with the node transforms applied, the materials they use
// (pbrMetallicRoughness, KHR_materials_transmission, KHR_materials_ior,
// KHR_materials_emissive_strength), KHR_lights_punctual lights and perspective cameras. Points
// and lines are skipped with a warning; glTF 1.0 files are refused with advice on converting
// them. Textures, skins and animation are ignored.
#pragma once

#include <filesystem>

#include "absl/status/statusor.h"
#include "renderer/scene/mesh_file.h"

namespace caustica {

// One Mesh per (node, primitive) pair; primitives without a material get kNoMaterial.
absl::StatusOr<MeshFile> load_gltf(const std::filesystem::path& path);

}  // namespace caustica
