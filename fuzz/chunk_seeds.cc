// Writes the scene_chunks fuzz target's seeds: real uploads of small bundled scenes, encoded the
// way the client encodes them (client/scene_upload.cc) but in 1 KiB chunks, so that a seed holds
// several chunks per array and mutations meet the offset bookkeeping.
//   caustica_fuzz_chunk_seeds <scenes dir> <output dir>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/util/delimited_message_util.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "absl/status/statusor.h"
#include "caustica/v1/scene.pb.h"
#include "fuzz/chunk_stream.h"
#include "fuzz/tiny_grid.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/affine.h"
#include "renderer/scene/load_scene.h"
#include "renderer/scene/validate.h"

namespace {

constexpr size_t kSeedChunkBytes = 1024;

bool write_seed(const caustica::Scene& scene, const std::string& name, uint8_t flags,
                const std::filesystem::path& out_dir) {
  std::string bytes(1, static_cast<char>(flags));
  google::protobuf::io::StringOutputStream stream(&bytes);
  bool written = true;
  caustica::v1::SceneChunk header;
  *header.mutable_header() = caustica::wire::encode_scene_header(scene, name);
  written &= google::protobuf::util::SerializeDelimitedToZeroCopyStream(header, &stream);
  caustica::wire::for_each_chunk(scene, kSeedChunkBytes, [&](caustica::v1::SceneChunk& chunk) {
    written &= google::protobuf::util::SerializeDelimitedToZeroCopyStream(chunk, &stream);
    return written;
  });
  const std::filesystem::path path = out_dir / (name + ".chunks");
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!written || !out) {
    std::fprintf(stderr, "chunk seeds: cannot write %s\n", path.c_str());
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s <scenes dir> <output dir>\n", argv[0]);
    return 2;
  }
  const std::filesystem::path scenes_dir = argv[1];
  const std::filesystem::path out_dir = argv[2];
  std::filesystem::create_directories(out_dir);
  bool ok = true;
  for (const char* name : {"cornell-box", "fog-box", "ring"}) {
    const absl::StatusOr<caustica::Scene> scene =
        caustica::load_scene(scenes_dir / name / "scene.json");
    if (!scene.ok()) {
      std::fprintf(stderr, "chunk seeds: %s\n", std::string(scene.status().message()).c_str());
      return 1;
    }
    ok &= write_seed(*scene, name, caustica::fuzz::kFixChecksums, out_dir);
    if (std::string(name) != "cornell-box") continue;
    // The same upload as the client sends it, checksums and all, for the checksum test.
    ok &= write_seed(*scene, "cornell-box-own-checksums", 0, out_dir);
    // And filled with a density grid, for the grid chunks and the grid checks behind them.
    caustica::Scene smoke = *scene;
    caustica::Medium medium;
    medium.name = "smoke";
    medium.type = caustica::MediumType::kGrid;
    medium.absorption = caustica::Vec3f(0.001f);
    medium.scattering = caustica::Vec3f(0.01f);
    medium.grid = caustica::fuzz::tiny_density_grid_bytes();
    medium.grid_source = "tiny";
    medium.grid_to_scene = caustica::translation(caustica::Vec3f(278, 273, 279)) *
                           caustica::scaling(caustica::Vec3f(40));
    smoke.media.push_back(medium);
    smoke.medium = 0;
    if (const absl::Status valid = caustica::validate_scene(smoke); !valid.ok()) {
      std::fprintf(stderr, "chunk seeds: %s\n", std::string(valid.message()).c_str());
      return 1;
    }
    ok &= write_seed(smoke, "cornell-box-grid", caustica::fuzz::kFixChecksums, out_dir);
  }
  return ok ? 0 : 1;
}
