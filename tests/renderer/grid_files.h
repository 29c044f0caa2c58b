// Density grids written by NanoVDB's own builder and writer, as other tools write them, for the
// tests that read them back.
#pragma once

#include <gtest/gtest.h>
#include <nanovdb/util/GridBuilder.h>
#include <nanovdb/util/IO.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "renderer/scene/scene.h"

namespace caustica::test_grids {

// A float grid over the voxels [0, n)^3 with `density(i, j, k)` in each (zeros left inactive),
// voxels `voxel` wide, its voxel (0, 0, 0) centred at `origin`.
inline nanovdb::GridHandle<nanovdb::HostBuffer> density_grid(
    int n, double voxel, nanovdb::Vec3d origin, const std::function<float(int, int, int)>& density,
    const std::string& name = "density", float background = 0.0f) {
  nanovdb::GridBuilder<float> builder(background, nanovdb::GridClass::FogVolume);
  auto acc = builder.getAccessor();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        if (const float d = density(i, j, k); d != background)
          acc.setValue(nanovdb::Coord(i, j, k), d);
  return builder.getHandle<>(voxel, origin, name);
}

// The grid's buffer as a scene holds it.
inline std::shared_ptr<const AlignedBytes> grid_bytes(
    const nanovdb::GridHandle<nanovdb::HostBuffer>& handle) {
  auto bytes = std::make_shared<AlignedBytes>(handle.size());
  std::memcpy(bytes->data(), handle.data(), handle.size());
  return bytes;
}

// A directory of the running test's own for the files it writes, removed with it.
class ScratchDirectory {
 public:
  ScratchDirectory()
      : path_(std::filesystem::temp_directory_path() /
              ("caustica-" + std::to_string(::getpid()) + "-" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name())) {
    std::filesystem::create_directories(path_);
  }
  ~ScratchDirectory() { std::filesystem::remove_all(path_); }
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

inline void write_grid(const std::filesystem::path& path,
                       const nanovdb::GridHandle<nanovdb::HostBuffer>& handle) {
  nanovdb::io::writeGrid<nanovdb::HostBuffer>(path.string(), handle);
}

}  // namespace caustica::test_grids
