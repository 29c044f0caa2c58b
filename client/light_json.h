// Lights files and animation scripts in JSON, with the field names of the scene file's `lights`
// (docs/scene-format.md): {"type": "point", "position": [x, y, z], "intensity": [r, g, b]}, ...
//
//   lights file (caustica light set --file):  {"lights": [...]}  or the bare array [...]
//   animation script (caustica animate --script): {"keyframes": [{"lights": [...], "passes": 2},
//     ...]}; a keyframe without "lights" keeps the lights of the one before, and may also carry
//     "camera": {"position", "look_at", "up", "fov"} (the scene file's camera without its size),
//     "emitters": [{"material", "radiance", "off"}] (as `light emit`),
//     "environment": {"intensity", "rotation"} and
//     "meshes": [{"mesh": name, "transform": {"translate", "rotate", "scale"}}] (where the mesh
//     stands, from where it was uploaded, as `mesh move`).
//
// Each light is read by the scene loader itself (scene_from_json), so a light means exactly what
// it means in a scene file. Errors start with the source name and name the keyframe and field:
// "orbit.json: keyframes[3]: lights[0].intensity: expected [x, y, z], got 5". Range checks (spot
// angles, negative intensity) and mesh names are the server's, which names the field the same way.
#pragma once

#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"

namespace caustica::client {

absl::StatusOr<std::vector<v1::Light>> parse_lights_file(std::string_view text,
                                                         std::string_view source_name);

absl::StatusOr<std::vector<v1::Keyframe>> parse_animation_script(std::string_view text,
                                                                 std::string_view source_name);

}  // namespace caustica::client
