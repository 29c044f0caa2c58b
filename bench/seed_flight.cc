#include "bench/seed_flight.h"

#include "absl/strings/str_cat.h"
#include "client/light_json.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/file_io.h"

namespace caustica {

absl::StatusOr<std::vector<FlightFrame>> load_flight(const std::filesystem::path& path,
                                                     const Camera& start, int width, int height) {
  const absl::StatusOr<std::string> text = read_file(path);
  if (!text.ok()) return text.status();
  absl::StatusOr<std::vector<v1::Keyframe>> keyframes =
      client::parse_animation_script(*text, path.string());
  if (!keyframes.ok()) return keyframes.status();
  std::vector<FlightFrame> frames;
  Camera camera = start;
  camera.width = width;
  camera.height = height;
  for (size_t i = 0; i < keyframes->size(); ++i) {
    const v1::Keyframe& keyframe = (*keyframes)[i];
    const std::string field = absl::StrCat(path.string(), ": keyframes[", i, "]");
    if (keyframe.has_camera()) {
      absl::StatusOr<Camera> moved =
          wire::decode_camera_at(keyframe.camera(), absl::StrCat(field, ".camera"), width, height);
      if (!moved.ok()) return moved.status();
      camera = *moved;
    }
    absl::StatusOr<std::vector<Light>> lights =
        wire::decode_lights(keyframe.lights(), absl::StrCat(field, ".lights"));
    if (!lights.ok()) return lights.status();
    frames.push_back({camera, *std::move(lights)});
  }
  return frames;
}

}  // namespace caustica
