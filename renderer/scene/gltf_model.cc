#include "renderer/scene/gltf_model.h"

#include <array>
#include <exception>
#include <fstream>
#include <nlohmann/json.hpp>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/strip.h"
#include "renderer/scene/file_io.h"
#include "renderer/scene/status_util.h"

namespace caustica {
namespace {

using Json = nlohmann::json;

bool keep_image_bytes(tinygltf::Image*, const int index, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void* user_data) {
  auto& images = *static_cast<ImageBytes*>(user_data);
  if (index < 0 || bytes == nullptr || size <= 0) return true;
  if (images.size() <= size_t(index)) images.resize(size_t(index) + 1);
  images[size_t(index)].assign(reinterpret_cast<const char*>(bytes), size_t(size));
  return true;
}

// Why a file is glTF 1.0, or empty when it is not. tinygltf reads such files as glTF 2.0 and fails
// on whatever 1.0 spells differently (dictionaries instead of arrays), with a message that does
// not say what is wrong; this looks first.
// Binary containers say their version in the header; only that is read of a large .glb.
std::string binary_gltf1_evidence(const std::filesystem::path& path) {
  char header[8] = {};
  std::ifstream in(path, std::ios::binary);
  in.read(header, sizeof(header));
  if (in.gcount() == sizeof(header) && std::memcmp(header, "glTF", 4) == 0) {
    uint32_t version = 0;
    std::memcpy(&version, header + 4, 4);
    if (version == 1) return "binary glTF (KHR_binary_glTF) container version 1";
  }
  return "";
}

// JSON files are looked at again only when tinygltf failed or found no meshes, so that the common
// case does not parse its JSON twice.
std::string json_gltf1_evidence(const std::filesystem::path& path) {
  absl::StatusOr<std::string> bytes = read_file(path);
  if (!bytes.ok()) return "";  // tinygltf reports unreadable files
  const Json json = Json::parse(*bytes, /*cb=*/nullptr, /*allow_exceptions=*/false);
  if (!json.is_object()) return "";  // not JSON: tinygltf says so
  const auto asset = json.find("asset");
  if (asset != json.end() && asset->is_object()) {
    const auto version = asset->find("version");
    if (version != asset->end() && version->is_string()) {
      const std::string v = version->get<std::string>();
      if (v == "1" || absl::StartsWith(v, "1.")) return absl::StrCat("asset.version \"", v, "\"");
    }
    return "";
  }
  for (const char* key : {"techniques", "programs", "shaders"}) {
    if (json.contains(key)) {
      return absl::StrCat("no asset object and a top-level \"", key, "\" object");
    }
  }
  for (const char* key : {"meshes", "accessors", "nodes"}) {
    const auto it = json.find(key);
    if (it != json.end() && it->is_object()) {
      return absl::StrCat("no asset object and \"", key, "\" is a dictionary, not an array");
    }
  }
  return "";
}

absl::Status reject_gltf1(const std::filesystem::path& path, const std::string& evidence) {
  if (evidence.empty()) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(
      path.string(), ": this is a glTF 1.0 file (", evidence,
      "); only glTF 2.0 is supported. Convert it to glTF 2.0 with the Khronos/Cesium "
      "glTF-Pipeline, which upgrades 1.0 files as it copies them: `npm install -g gltf-pipeline` "
      "then `gltf-pipeline -i in.gltf -o out.gltf` (or `-o out.glb`)"));
}

}  // namespace

absl::StatusOr<tinygltf::Model> load_gltf_model(const std::filesystem::path& path,
                                                ImageBytes* images) {
  if (absl::Status file = check_regular_file(path); !file.ok()) return file;
  SCENE_RETURN_IF_ERROR(reject_gltf1(path, binary_gltf1_evidence(path)));
  tinygltf::TinyGLTF loader;
  ImageBytes ignored;
  loader.SetImageLoader(&keep_image_bytes, images != nullptr ? images : &ignored);
  tinygltf::Model model;
  std::string error, warning;
  bool loaded = false;
  const bool binary = absl::AsciiStrToLower(path.extension().string()) == ".glb";
  try {
    loaded = binary ? loader.LoadBinaryFromFile(&model, &error, &warning, path.string())
                    : loader.LoadASCIIFromFile(&model, &error, &warning, path.string());
  } catch (const std::exception& e) {
    error = e.what();
  }
  if (!loaded || model.meshes.empty() || absl::StartsWith(model.asset.version, "1")) {
    SCENE_RETURN_IF_ERROR(reject_gltf1(path, json_gltf1_evidence(path)));
  }
  if (!loaded) {
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": ", absl::StripTrailingAsciiWhitespace(error)));
  }
  return model;
}

std::vector<int> gltf_root_nodes(const tinygltf::Model& model) {
  if (!model.scenes.empty()) {
    const size_t scene =
        model.defaultScene >= 0 && static_cast<size_t>(model.defaultScene) < model.scenes.size()
            ? model.defaultScene
            : 0;
    return model.scenes[scene].nodes;
  }
  std::vector<bool> is_child(model.nodes.size(), false);
  for (const tinygltf::Node& node : model.nodes) {
    for (const int child : node.children) {
      if (child >= 0 && static_cast<size_t>(child) < is_child.size()) is_child[child] = true;
    }
  }
  std::vector<int> roots;
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    if (!is_child[i]) roots.push_back(static_cast<int>(i));
  }
  return roots;
}

Affine gltf_local_transform(const tinygltf::Node& node) {
  if (node.matrix.size() == 16) {
    std::array<double, 16> columns;
    std::copy(node.matrix.begin(), node.matrix.end(), columns.begin());
    return from_column_major(columns);
  }
  const auto vec3 = [](const std::vector<double>& v) {
    return Vec3f(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
  };
  Affine t;
  if (node.translation.size() == 3) t = translation(vec3(node.translation));
  if (node.rotation.size() == 4) {
    t = t *
        rotation_quaternion(node.rotation[0], node.rotation[1], node.rotation[2], node.rotation[3]);
  }
  if (node.scale.size() == 3) t = t * scaling(vec3(node.scale));
  return t;
}

std::string gltf_primitive_name(const tinygltf::Model& model, int node, size_t primitive) {
  const tinygltf::Node& n = model.nodes[size_t(node)];
  return absl::StrCat("mesh '", model.meshes[size_t(n.mesh)].name, "' primitive ", primitive,
                      " at node '", n.name.empty() ? absl::StrCat(node) : n.name, "'");
}

bool gltf_draws_triangles(const tinygltf::Primitive& primitive) {
  // tinygltf leaves mode at -1 when the file omits it; glTF's default is TRIANGLES.
  const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
  return mode == TINYGLTF_MODE_TRIANGLES || mode == TINYGLTF_MODE_TRIANGLE_STRIP ||
         mode == TINYGLTF_MODE_TRIANGLE_FAN;
}

}  // namespace caustica
