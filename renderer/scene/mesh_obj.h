// Wavefront OBJ meshes and their MTL materials, read through tinyobjloader. Polygons are
// fan-triangulated; vertices are shared only where position, normal and texture coordinate all
// match. MTL maps to our materials as documented in docs/scene-format.md (Ke -> emissive,
// glass illumination models or d < 1 -> dielectric with Ni, illum 3/5/8 -> mirror with Ks, a
// nonblack Ks under any other illum but 0 and 1 -> modified Phong with Kd, Ks and Ns, otherwise
// diffuse with Kd).
#pragma once

#include <filesystem>

#include "absl/status/statusor.h"
#include "renderer/scene/mesh_file.h"

namespace caustica {

// One mesh for the whole file. Faces without usemtl get kNoMaterial.
absl::StatusOr<MeshFile> load_obj(const std::filesystem::path& path);

}  // namespace caustica
