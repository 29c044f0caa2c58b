// A glTF file's animation sampled on the CPU: node translation, rotation and scale channels and
// morph target weights, with STEP, LINEAR and CUBICSPLINE interpolation, and linear blend skins.
// What it yields at a time is the mesh changes (scene.h's MeshChange) that place and reshape the
// meshes load_mesh_file makes of the file, so that UpdateGeometry or an animation's keyframes can
// play it. docs/dynamic.md says what is read and what is not.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "renderer/scene/affine.h"
#include "renderer/scene/scene.h"

namespace caustica {

class GltfAnimation {
 public:
  // The animation of `path` named `animation`, or numbered so ("0"), or the file's first when
  // empty. Errors name the file, and the animation, channel or accessor that is wrong; an unknown
  // animation's error lists the file's.
  static absl::StatusOr<GltfAnimation> load(const std::filesystem::path& path,
                                            const std::string& animation);

  const std::string& name() const;  // the file's name for it, or its number
  double duration_s() const;        // the last key time of any of its channels
  size_t meshes() const;            // how many meshes it moves or reshapes

  // Every mesh the animation moves or reshapes, at `seconds` (held at the first and last keys
  // outside them), named as load_mesh_file names them: a mesh that moves rigidly by the transform
  // from where the file's rest pose put it; a skinned or morphed one by new positions (and
  // normals) where the file's space has them, with an identity transform.
  std::vector<MeshChange> at(double seconds) const;

  struct Data;

 private:
  explicit GltfAnimation(std::shared_ptr<const Data> data) : data_(std::move(data)) {}
  std::shared_ptr<const Data> data_;
};

// `changes` (file-level names and space, as GltfAnimation::at gives them) for the meshes a scene
// file's shape made of the file: named under the shape's path and name as the scene reader names
// them (shape_label), and placed by the shape's transform.
void place_in_shape(const std::string& shape_path, const std::string& shape_name,
                    const Affine& shape_transform, std::vector<MeshChange>& changes);

}  // namespace caustica
