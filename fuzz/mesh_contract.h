// The contract of load_mesh_file's result (renderer/scene/mesh_file.h) that the scene reader
// relies on without checking: it offsets material ids and places meshes as they come.
#pragma once

#include "fuzz/fuzz_scratch.h"
#include "renderer/scene/mesh_file.h"

namespace caustica::fuzz {

inline void check_mesh_file(const MeshFile& file) {
  for (const Mesh& mesh : file.meshes) {
    CAUSTICA_FUZZ_CHECK(mesh.indices.size() % 3 == 0, "indices come in triangles");
    for (const uint32_t index : mesh.indices) {
      CAUSTICA_FUZZ_CHECK(index < mesh.positions.size(), "every index names a vertex");
    }
    CAUSTICA_FUZZ_CHECK(mesh.material_ids.size() == mesh.triangle_count(),
                        "one material id per triangle");
    for (const uint32_t id : mesh.material_ids) {
      CAUSTICA_FUZZ_CHECK(id == kNoMaterial || id < file.materials.size(),
                          "material ids index the file's materials");
    }
    CAUSTICA_FUZZ_CHECK(mesh.normals.empty() || mesh.normals.size() == mesh.positions.size(),
                        "normals for every vertex or none");
    CAUSTICA_FUZZ_CHECK(mesh.uvs.empty() || mesh.uvs.size() == mesh.positions.size(),
                        "texture coordinates for every vertex or none");
  }
}

}  // namespace caustica::fuzz
