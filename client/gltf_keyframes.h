// Keyframes from the glTF animations of a scene's models, for `caustica animate
// --gltf-animation`: the named animation of every glTF shape of the scene file (or of a bare
// .gltf/.glb scene) sampled at the frame rate, as the mesh changes of one keyframe per frame.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"

namespace caustica::client {

// The animation `animation` (a name, or a number as "0") of each glTF the scene file `scene`
// names, sampled at frame i / fps. With a `script`, its keyframes get the animation's changes,
// frame for keyframe; without one, each frame is a keyframe of its own that keeps the lights, as
// many as the longest animation lasts. NOT_FOUND when no model of the scene has the animation.
absl::StatusOr<std::vector<v1::Keyframe>> gltf_keyframes(const std::filesystem::path& scene,
                                                         const std::string& animation, int fps,
                                                         std::vector<v1::Keyframe> script);

}  // namespace caustica::client
