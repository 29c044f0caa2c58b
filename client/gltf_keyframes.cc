#include "client/gltf_keyframes.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/file_io.h"
#include "renderer/scene/gltf_animation.h"
#include "renderer/scene/json_fields.h"

namespace caustica::client {
namespace {

bool is_gltf(const std::filesystem::path& path) {
  const std::string extension = absl::AsciiStrToLower(path.extension().string());
  return extension == ".gltf" || extension == ".glb";
}

// A glTF model of the scene and where the scene file puts it.
struct AnimatedShape {
  std::filesystem::path file;
  std::optional<std::string> path;  // "shapes[2]"; none for a bare model file
  std::string name;
  Affine transform;
};

// The scene file's glTF shapes, read as the scene reader reads them (scene_json.cc).
absl::StatusOr<std::vector<AnimatedShape>> gltf_shapes(const std::filesystem::path& scene) {
  if (is_gltf(scene)) return std::vector<AnimatedShape>{{scene, std::nullopt, "", Affine()}};
  absl::StatusOr<std::string> text = read_file(scene);
  if (!text.ok()) return text.status();
  const Json root = Json::parse(*text, nullptr, /*allow_exceptions=*/false,
                                /*ignore_comments=*/true);
  std::vector<AnimatedShape> shapes;
  if (!root.is_object() || !root.contains("shapes") || !root["shapes"].is_array()) return shapes;
  const Json& list = root["shapes"];
  for (size_t i = 0; i < list.size(); ++i) {
    const Json& shape = list[i];
    if (!shape.is_object() || !shape.contains("file") || !shape["file"].is_string()) continue;
    AnimatedShape s;
    s.file = scene.parent_path() / shape["file"].get<std::string>();
    if (!is_gltf(s.file)) continue;
    s.path = absl::StrCat("shapes[", i, "]");
    if (shape.contains("name") && shape["name"].is_string()) s.name = shape["name"];
    if (shape.contains("transform")) {
      absl::StatusOr<Affine> transform =
          read_transform(shape["transform"], absl::StrCat(*s.path, ".transform"));
      if (!transform.ok()) {
        return absl::Status(transform.status().code(),
                            absl::StrCat(scene.string(), ": ", transform.status().message()));
      }
      s.transform = *transform;
    }
    shapes.push_back(std::move(s));
  }
  return shapes;
}

}  // namespace

absl::StatusOr<std::vector<v1::Keyframe>> gltf_keyframes(const std::filesystem::path& scene,
                                                         const std::string& animation, int fps,
                                                         std::vector<v1::Keyframe> script) {
  absl::StatusOr<std::vector<AnimatedShape>> shapes = gltf_shapes(scene);
  if (!shapes.ok()) return shapes.status();
  std::vector<std::pair<const AnimatedShape*, GltfAnimation>> playing;
  std::vector<std::string> why_not;
  for (const AnimatedShape& shape : *shapes) {
    absl::StatusOr<GltfAnimation> loaded = GltfAnimation::load(shape.file, animation);
    if (loaded.ok()) {
      playing.emplace_back(&shape, *std::move(loaded));
    } else {
      why_not.push_back(std::string(loaded.status().message()));
    }
  }
  if (playing.empty()) {
    return absl::NotFoundError(
        absl::StrCat("--gltf-animation: no glTF model of ", scene.string(), " has the animation '",
                     animation, "'", why_not.empty() ? " (it names no .gltf or .glb file)" : ": ",
                     absl::StrJoin(why_not, "; ")));
  }
  double duration = 0;
  for (const auto& [shape, clip] : playing) duration = std::max(duration, clip.duration_s());
  const size_t frames =
      script.empty() ? size_t(std::floor(duration * fps + 1e-9)) + 1 : script.size();
  std::vector<v1::Keyframe> keyframes = std::move(script);
  const size_t scripted = keyframes.size();
  keyframes.resize(frames);
  for (size_t i = 0; i < frames; ++i) {
    v1::Keyframe& keyframe = keyframes[i];
    if (i >= scripted) keyframe.set_keep_lights(true);  // a frame of its own keeps the lights
    for (const auto& [shape, clip] : playing) {
      std::vector<MeshChange> changes = clip.at(double(i) / fps);
      if (shape->path) place_in_shape(*shape->path, shape->name, shape->transform, changes);
      for (const MeshChange& change : changes)
        *keyframe.add_meshes() = wire::encode_mesh_change(change);
    }
  }
  return keyframes;
}

}  // namespace caustica::client
