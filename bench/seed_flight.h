// A scene's flight (the seeds' appendix A.2, scenes/*/flight.json): the animation script of
// `caustica animate`, read into the camera and lights of each frame.
#pragma once

#include <filesystem>
#include <vector>

#include "absl/status/statusor.h"
#include "renderer/scene/scene.h"

namespace caustica {

struct FlightFrame {
  Camera camera;
  std::vector<Light> lights;
};

// Every keyframe of the script at `path`, each camera at width x height; a keyframe without a
// camera keeps the one before it (the first: `start`), as the server plays them.
absl::StatusOr<std::vector<FlightFrame>> load_flight(const std::filesystem::path& path,
                                                     const Camera& start, int width, int height);

}  // namespace caustica
