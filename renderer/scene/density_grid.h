// Density grids of heterogeneous media (docs/media.md, "Density grids"): NanoVDB float grids,
// read from .nvdb files with NanoVDB's own reader, and checked whole before anything samples
// them, since their buffers also arrive over the wire from clients.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "renderer/base/aabb.h"
#include "renderer/scene/affine.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Grid `grid_name` of the NanoVDB file `path` ("" for its first grid), checked as
// check_density_grid does. Errors start with `field` and name the file.
absl::StatusOr<std::shared_ptr<const AlignedBytes>> read_density_grid(
    const std::filesystem::path& path, const std::string& grid_name, const std::string& field);

// Whether `bytes` are one whole NanoVDB float grid: its header, checksum and every node inside
// the buffer, a background of 0 (the medium ends where the grid does) and no negative or
// non-finite value. Errors start with `field`.
absl::Status check_density_grid(const AlignedBytes& bytes, const std::string& field);

// What kernels need of a checked grid standing where `grid_to_scene` puts it.
struct DensityGridFacts {
  Aabb bounds;               // in the scene: outside it the density is 0
  float max_density = 0.0f;  // over every value the grid holds
  float step = 0.0f;         // half the shortest voxel edge, in the scene's units
  std::array<std::array<float, 4>, 3> scene_to_index{};  // a scene point to the grid's voxels
  uint64_t active_voxels = 0;
};
DensityGridFacts density_grid_facts(const AlignedBytes& bytes, const Affine& grid_to_scene);

}  // namespace caustica
