// PLY meshes (Turk's polygon file format, as written by the Stanford 3D scanning repository,
// Blender, MeshLab): ascii, binary_little_endian and binary_big_endian bodies, gzip-compressed
// files read transparently. Reads vertex x/y/z, optional nx/ny/nz and u/v (or s/t), and the face
// list "vertex_indices" (or "vertex_index") with any count and index types; polygons are
// fan-triangulated. Other elements and properties are skipped.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Every triangle's material id is kNoMaterial: PLY carries no materials. Header lines that start
// with no PLY keyword are skipped as comments, each with a sentence added to `warnings`.
absl::StatusOr<Mesh> load_ply(const std::filesystem::path& path,
                              std::vector<std::string>* warnings = nullptr);

// The same from bytes already in memory (uncompressed); `name` names them in errors, which give
// the line for ascii data and the byte offset for binary data.
absl::StatusOr<Mesh> parse_ply(absl::string_view bytes, absl::string_view name,
                               std::vector<std::string>* warnings = nullptr);

}  // namespace caustica
