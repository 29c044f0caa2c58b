// A small NanoVDB density grid for the fuzz targets' fixtures and seeds. Every NanoVDB grid holds
// at least one upper node of 32^3 entries, some 270 KiB, so this is about as small as a grid gets:
// one node of each level, all voxels at non-negative coordinates (a block across the origin
// would take eight of each).
#pragma once

#include <nanovdb/util/GridBuilder.h>

#include <cstring>
#include <memory>

#include "renderer/scene/scene.h"

namespace caustica::fuzz {

// A 6^3 block of voxels, 1 wide, voxel (0, 0, 0) centred at (-3, -3, -3): density 0.5, 1 on the
// block's diagonal.
inline nanovdb::GridHandle<nanovdb::HostBuffer> tiny_density_grid() {
  nanovdb::GridBuilder<float> builder(0.0f, nanovdb::GridClass::FogVolume);
  auto voxels = builder.getAccessor();
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      for (int k = 0; k < 6; ++k)
        voxels.setValue(nanovdb::Coord(i, j, k), i == j && j == k ? 1.0f : 0.5f);
  return builder.getHandle<>(1.0, nanovdb::Vec3d(-3.0), "density");
}

inline std::shared_ptr<const AlignedBytes> tiny_density_grid_bytes() {
  const nanovdb::GridHandle<nanovdb::HostBuffer> handle = tiny_density_grid();
  auto bytes = std::make_shared<AlignedBytes>(handle.size());
  std::memcpy(bytes->data(), handle.data(), handle.size());
  return bytes;
}

}  // namespace caustica::fuzz
