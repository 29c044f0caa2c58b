// A whole scene around one bare model file (.obj, .ply, .gltf, .glb or an Assimp format), for
// rendering a model without writing a scene JSON: the file's meshes, a camera that frames them, a
// floor under them and a light above them, unless the file brings its own camera and lights
// (glTF). load_scene dispatches here by extension; docs/scene-format.md, "Bare mesh files".
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "renderer/scene/mesh_file.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Axis-aligned bounds of every position of the meshes; lo > hi when there is none.
struct Bounds {
  Vec3f lo{1, 1, 1};
  Vec3f hi{-1, -1, -1};
  bool empty() const { return lo.x > hi.x; }
  Vec3f center() const { return (lo + hi) * 0.5f; }
  Vec3f size() const { return hi - lo; }
};
Bounds mesh_bounds(const std::vector<Mesh>& meshes);

// A camera of `image`'s resolution (its other fields are replaced) that looks at the bounds from
// the front (+z) and above (+y), far enough that the bounding sphere, and so every corner of the
// box, lies inside the image with a margin. Needs non-empty bounds.
Camera frame_bounds(const Bounds& bounds, const Camera& image);

// Loads the model and builds the scene around it, validated. Warnings of the loader (skipped
// primitives, unused cameras) and of the framing go to `warnings` when given. Errors name the
// file.
absl::StatusOr<Scene> load_mesh_scene(const std::filesystem::path& path,
                                      std::vector<std::string>* warnings = nullptr);

// The same for a file already loaded; `source_name` names it in errors and `z_up` turns a z-up
// file (3D-printing formats) to the scene's y-up first.
absl::StatusOr<Scene> scene_around_mesh_file(MeshFile file, std::string_view source_name, bool z_up,
                                             std::vector<std::string>* warnings);

}  // namespace caustica
