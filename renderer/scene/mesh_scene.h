// A whole scene around one bare model file (.obj, .ply, .gltf, .glb or an Assimp format), for
// rendering a model without writing a scene JSON: the file's meshes, a camera that frames them, a
// floor under them and a light above them, unless the file brings its own camera and lights; an
// interior is seen and lit from inside. load_scene dispatches here by extension;
// docs/scene-format.md, "Bare mesh files".
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

// Whether the meshes enclose `center` as a building or a room does: of 32 rays from it spread
// evenly over the sphere, more than half meet a triangle, and more than half of those meet its
// front face (a room's walls face in; a closed solid's inside faces away). Brute force over every
// triangle. `mean_distance` of the rays that hit; `above`, how far above the centre the lowest
// hit of a ray within 25 degrees of straight up lies, or < 0 for none.
struct Enclosure {
  bool encloses = false;
  float mean_distance = 0;
  float above = -1;
};
Enclosure enclosure_of(const std::vector<Mesh>& meshes, Vec3f center);

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
