// caustica-make-cloud: writes a procedural cloud as a NanoVDB density grid, the kind of file a
// grid medium reads (docs/media.md, "Density grids"). scenes/smoke-box's cloud came from it.
#include <nanovdb/util/GridBuilder.h>
#include <nanovdb/util/IO.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>

namespace {

// A hash of a lattice point to [0, 1).
float lattice(int x, int y, int z, uint32_t seed) {
  uint32_t h = seed ^ (uint32_t(x) * 0x8da6b343u) ^ (uint32_t(y) * 0xd8163841u) ^
               (uint32_t(z) * 0xcb1ab31fu);
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return float(h >> 8) * (1.0f / 16777216.0f);
}

// Value noise: the lattice's values blended by smoothstep weights.
float value_noise(float x, float y, float z, uint32_t seed) {
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y)), z0 = int(std::floor(z));
  auto smooth = [](float t) { return t * t * (3.0f - 2.0f * t); };
  const float u = smooth(x - x0), v = smooth(y - y0), w = smooth(z - z0);
  float sum = 0.0f;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    sum += (dx ? u : 1 - u) * (dy ? v : 1 - v) * (dz ? w : 1 - w) *
           lattice(x0 + dx, y0 + dy, z0 + dz, seed);
  }
  return sum;
}

// Four octaves of value noise, in [0, 1).
float fractal_noise(float x, float y, float z, uint32_t seed) {
  float sum = 0.0f, amplitude = 0.5f, norm = 0.0f;
  for (int octave = 0; octave < 4; ++octave) {
    sum += amplitude * value_noise(x, y, z, seed + uint32_t(octave));
    norm += amplitude;
    amplitude *= 0.5f;
    x *= 2.0f;
    y *= 2.0f;
    z *= 2.0f;
  }
  return sum / norm;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "Writes a procedural cloud as a NanoVDB float grid named \"density\": noise inside "
      "a ball, densest at its heart, 0 outside.");
  std::string out;
  int voxels = 48;
  uint32_t seed = 1;
  app.add_option("output", out, "the .nvdb file to write")->required();
  app.add_option("--voxels", voxels, "voxels along each side of the grid")
      ->check(CLI::Range(8, 1024));
  app.add_option("--seed", seed, "the noise's seed");
  CLI11_PARSE(app, argc, argv);

  nanovdb::GridBuilder<float> builder(0.0f, nanovdb::GridClass::FogVolume);
  auto acc = builder.getAccessor();
  const float half = 0.5f * float(voxels);
  for (int i = 0; i < voxels; ++i) {
    for (int j = 0; j < voxels; ++j) {
      for (int k = 0; k < voxels; ++k) {
        const float x = (float(i) + 0.5f - half) / half, y = (float(j) + 0.5f - half) / half,
                    z = (float(k) + 0.5f - half) / half;
        const float r = std::sqrt(x * x + y * y + z * z);
        const float noise = fractal_noise(3.0f * x + 7.0f, 3.0f * y, 3.0f * z, seed);
        const float density = std::clamp(2.2f * noise - 1.6f * r * r, 0.0f, 1.0f);
        if (density > 0.0f) acc.setValue(nanovdb::Coord(i, j, k), density);
      }
    }
  }
  try {
    auto handle = builder.getHandle<>(1.0, nanovdb::Vec3d(0.0), "density");
    nanovdb::io::writeGrid<nanovdb::HostBuffer>(out, handle);
    std::printf("%s: %d^3 voxels, %llu active, %llu bytes\n", out.c_str(), voxels,
                static_cast<unsigned long long>(handle.grid<float>()->activeVoxelCount()),
                static_cast<unsigned long long>(handle.size()));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "caustica-make-cloud: %s: %s\n", out.c_str(), e.what());
    return 1;
  }
  return 0;
}
