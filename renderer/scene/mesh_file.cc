#include "renderer/scene/mesh_file.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "renderer/scene/mesh_assimp.h"
#include "renderer/scene/mesh_gltf.h"
#include "renderer/scene/mesh_obj.h"
#include "renderer/scene/mesh_ply.h"
#include "renderer/scene/status_util.h"

namespace caustica {

float conserve_phong_energy(Material* material) {
  const Vec3f kd = material->color, ks = material->specular;
  if (!is_finite(kd) || !is_finite(ks)) return 1;  // validation refuses these
  const Vec3f sum = kd + ks;
  const float worst = std::max({sum.x, sum.y, sum.z});
  if (!(worst > 1 && std::isfinite(worst))) return 1;
  // 1 / worst may leave a sum a rounding step above 1; step the factor down until none is.
  const auto conserves = [&](float scale) {
    const Vec3f scaled = kd * scale + ks * scale;
    return scaled.x <= 1 && scaled.y <= 1 && scaled.z <= 1;
  };
  float scale = 1 / worst;
  while (!conserves(scale)) scale = std::nextafter(scale, 0.0f);
  material->color = kd * scale;
  material->specular = ks * scale;
  return scale;
}

absl::StatusOr<MeshFile> load_mesh_file(const std::filesystem::path& path) {
  std::string extension = absl::AsciiStrToLower(path.extension().string());
  if (extension == ".gz") {
    // Only PLY is read through zlib; the other loaders open their files themselves.
    extension = absl::AsciiStrToLower(path.stem().extension().string());
    if (extension != ".ply") {
      return absl::InvalidArgumentError(
          absl::StrCat(path.string(), ": only .ply files may be gzip-compressed"));
    }
  }
  if (extension == ".ply") {
    // Assimp is not asked when the own reader refuses a file: its PLY reader (5.2.5) never returns
    // from a header without its end and reads face counts beyond the limits for minutes.
    MeshFile file;
    SCENE_ASSIGN_OR_RETURN(Mesh mesh, load_ply(path, &file.warnings));
    file.meshes.push_back(std::move(mesh));
    return file;
  }
  if (extension == ".obj") return load_obj(path);
  if (extension == ".gltf" || extension == ".glb") return load_gltf(path);
  // Scene JSON is never a mesh, whatever an importer might make of it.
  if (extension != ".json" && assimp_reads_extension(extension)) return load_assimp(path);
  return absl::InvalidArgumentError(absl::StrCat(
      path.string(), ": unsupported mesh format '", extension,
      "' (expected .obj, .ply, .ply.gz, .gltf, .glb or a format Assimp imports, such as .fbx, "
      ".dae, .stl, .3mf, .off or .3ds)"));
}

bool is_mesh_file_name(const std::filesystem::path& path) {
  std::string extension = absl::AsciiStrToLower(path.extension().string());
  if (extension == ".gz") extension = absl::AsciiStrToLower(path.stem().extension().string());
  if (extension == ".ply" || extension == ".obj" || extension == ".gltf" || extension == ".glb") {
    return true;
  }
  return extension != ".json" && assimp_reads_extension(extension);
}

void UnreadMaps::note(std::string_view kind, const std::string& file) {
  auto it =
      std::find_if(kinds_.begin(), kinds_.end(), [&](const Kind& k) { return k.name == kind; });
  if (it == kinds_.end()) it = kinds_.insert(kinds_.end(), Kind{std::string(kind), {}, 0});
  it->files.insert(file);
  ++it->materials;
}

void UnreadMaps::warn(const std::string& file_name, std::vector<std::string>& warnings) const {
  for (const Kind& kind : kinds_) {
    warnings.push_back(absl::StrCat(file_name, ": its ", kind.name, " maps are not read (",
                                    kind.materials, " material", kind.materials > 1 ? "s" : "",
                                    "): ", absl::StrJoin(kind.files, ", ")));
  }
}

}  // namespace caustica
