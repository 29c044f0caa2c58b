#include "renderer/scene/mesh_obj.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "absl/strings/strip.h"
#include "renderer/scene/file_io.h"
#include "renderer/scene/mesh_file.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/status_util.h"
#include "renderer/scene/texture_files.h"

namespace caustica {
namespace {

Vec3f to_vec3(const tinyobj::real_t* v) { return {v[0], v[1], v[2]}; }

// `file_name` names the OBJ in the warning of a Phong material scaled to conserve energy.
// Whether the material uses the PBR extension of MTL that Blender's exporter and tinyobjloader
// know (Pr roughness, Pm metalness and their maps). tinyobj reports an absent Pr or Pm as 0, so a
// material whose two factors are 0 and that names neither map reads as one without it.
bool has_pbr_extension(const tinyobj::material_t& mtl) {
  return mtl.roughness != 0 || mtl.metallic != 0 || !mtl.roughness_texname.empty() ||
         !mtl.metallic_texname.empty();
}

// A factor of the PBR extension, clamped to [0, 1] with a warning naming it when it is not there.
float pbr_factor(float value, const char* name, const std::string& material,
                 const std::string& file_name, std::vector<std::string>& warnings) {
  const float clamped = std::isfinite(value) ? std::clamp(value, 0.0f, 1.0f) : 0.0f;
  if (clamped != value) {
    warnings.push_back(absl::StrCat(file_name, ": material '", material, "': ", name, " ", value,
                                    " is outside [0, 1]; read as ", clamped));
  }
  return clamped;
}

Material convert_material(const tinyobj::material_t& mtl, size_t index,
                          const std::string& file_name, std::vector<std::string>& warnings) {
  Material m;
  m.name = mtl.name.empty() ? absl::StrCat("material ", index) : mtl.name;
  const Vec3f emission = to_vec3(mtl.emission);
  // MTL illumination models 4, 6, 7 and 9 are the glass ones.
  const bool glass = mtl.illum == 4 || mtl.illum == 6 || mtl.illum == 7 || mtl.illum == 9;
  // Ke comes on top of what the surface reflects; a surface that reflects nothing is a light.
  m.radiance = emission;
  if (!is_black(emission) && !glass && is_black(to_vec3(mtl.diffuse)) &&
      is_black(to_vec3(mtl.specular))) {
    m.type = MaterialType::kEmissive;
    m.color = Vec3f(0);
  } else if (glass || mtl.dissolve < 1) {
    m.type = MaterialType::kDielectric;
    // tinyobj reports 1 when Ni is absent, and glass of index 1 would be invisible.
    m.ior = mtl.ior > 1 ? mtl.ior : 1.5f;
    if (has_pbr_extension(mtl))
      m.roughness = pbr_factor(mtl.roughness, "Pr", m.name, file_name, warnings);
  } else if (has_pbr_extension(mtl)) {
    // The PBR extension's material is glTF's: Kd the base colour, Pm the metalness, Pr the
    // perceptual roughness; Ks and Ns have no part in it.
    m.type = MaterialType::kMetallicRoughness;
    m.color = to_vec3(mtl.diffuse);
    m.metallic = pbr_factor(mtl.metallic, "Pm", m.name, file_name, warnings);
    m.roughness = pbr_factor(mtl.roughness, "Pr", m.name, file_name, warnings);
  } else if (mtl.illum == 3 || mtl.illum == 5 || mtl.illum == 8) {
    // The MTL specification's ray-traced reflection: a perfect mirror of colour Ks.
    m.type = MaterialType::kMirror;
    m.color = to_vec3(mtl.specular);
  } else if (!is_black(to_vec3(mtl.specular)) && mtl.illum != 0 && mtl.illum != 1) {
    // Illumination models 0 and 1 have no highlight whatever Ks says; the others add Ks's
    // Phong lobe of exponent Ns to Kd's diffuse one.
    m.type = MaterialType::kPhong;
    m.color = to_vec3(mtl.diffuse);
    m.specular = to_vec3(mtl.specular);
    m.exponent = mtl.shininess > 0 ? mtl.shininess : 1.0f;
    if (const float scale = conserve_phong_energy(&m); scale != 1) {
      const Vec3f sum = to_vec3(mtl.diffuse) + to_vec3(mtl.specular);
      warnings.push_back(absl::StrCat(file_name, ": material '", m.name, "': Kd + Ks = (", sum.x,
                                      ", ", sum.y, ", ", sum.z, ") exceeds 1; both scaled by ",
                                      scale, " so that it reflects no more than it receives"));
    }
  } else {
    m.type = MaterialType::kDiffuse;
    m.color = to_vec3(mtl.diffuse);
  }
  return m;
}

// One warning per kind of MTL map that no model reads (map_Ka, map_Ks, map_Ns, disp, refl, map_Ps),
// naming its files and counting the materials, so that a model that looks flatter than its author
// made it says why.
void warn_of_unread_maps(const std::vector<tinyobj::material_t>& materials,
                         const std::string& file_name, std::vector<std::string>& warnings) {
  using Field = std::string tinyobj::material_t::*;
  static const std::pair<Field, const char*> kUnread[] = {
      {&tinyobj::material_t::ambient_texname, "map_Ka"},
      {&tinyobj::material_t::specular_texname, "map_Ks"},
      {&tinyobj::material_t::specular_highlight_texname, "map_Ns"},
      {&tinyobj::material_t::displacement_texname, "disp"},
      {&tinyobj::material_t::reflection_texname, "refl"},
      {&tinyobj::material_t::sheen_texname, "map_Ps"},
  };
  UnreadMaps unread;
  for (const auto& [field, kind] : kUnread) {
    for (const tinyobj::material_t& mtl : materials)
      if (!(mtl.*field).empty()) unread.note(kind, mtl.*field);
  }
  unread.warn(file_name, warnings);
}

// An MTL map (`map_Kd file` with its options) as a texture of the scene. MTL's coordinates put v up
// the image, the scene's down it (glTF's), so -o and -s are turned: v' = s v + o upward is
// s v + (1 - s - o) downward.
TextureRef convert_map(const std::string& file, const tinyobj::texture_option_t& options,
                       TextureTable& textures, std::vector<std::string>& warnings) {
  TextureRef ref;
  if (file.empty()) return ref;
  ref.texture = textures.from_file(file, warnings);
  if (!ref.used()) return ref;
  if (options.clamp) ref.wrap_u = ref.wrap_v = TextureWrap::kClampToEdge;
  ref.transform.scale = {options.scale[0], options.scale[1]};
  ref.transform.offset = {options.origin_offset[0],
                          1.0f - options.scale[1] - options.origin_offset[1]};
  return ref;
}

// Line of the face_number-th (0-based) "f" statement: tinyobj keeps faces in file order but not
// their lines, and an error without a line is hard to act on. Only called on the error path.
size_t face_line(const std::filesystem::path& path, size_t face_number) {
  const absl::StatusOr<std::string> text = read_file(path);
  if (!text.ok()) return 0;
  size_t line_number = 0;
  for (absl::string_view line : absl::StrSplit(*text, '\n')) {
    ++line_number;
    line = absl::StripLeadingAsciiWhitespace(line);
    if (line.size() >= 2 && line[0] == 'f' && (line[1] == ' ' || line[1] == '\t')) {
      if (face_number-- == 0) return line_number;
    }
  }
  return 0;
}

// tinyobjloader keeps a face's corner count in an unsigned char: a face of 256 or more corners
// keeps all its indices but a wrapped count, which would pair the following faces with the wrong
// corners. The error names the first such face, found again in the text (only on this path).
absl::Status long_face_error(const std::filesystem::path& path) {
  constexpr size_t kMaxCorners = 255;
  const absl::StatusOr<std::string> text = read_file(path);
  size_t line_number = 0;
  if (text.ok()) {
    for (absl::string_view line : absl::StrSplit(*text, '\n')) {
      ++line_number;
      line = absl::StripLeadingAsciiWhitespace(line);
      if (line.size() < 2 || line[0] != 'f' || (line[1] != ' ' && line[1] != '\t')) continue;
      const std::vector<absl::string_view> corners =
          absl::StrSplit(line.substr(1), absl::ByAnyChar(" \t\r"), absl::SkipEmpty());
      if (corners.size() > kMaxCorners) {
        return absl::InvalidArgumentError(
            absl::StrCat(path.string(), ":", line_number, ": face has ", corners.size(),
                         " vertices; at most ", kMaxCorners, " are supported (split it)"));
      }
    }
  }
  return absl::InvalidArgumentError(absl::StrCat(path.string(), ": a face has more than ",
                                                 kMaxCorners, " vertices; at most ", kMaxCorners,
                                                 " are supported (split it)"));
}

// A face corner as OBJ stores it: separate indices into positions, normals and texcoords.
struct Corner {
  int position, normal, uv;
  bool operator==(const Corner&) const = default;
};
struct CornerHash {
  size_t operator()(const Corner& c) const {
    return std::hash<uint64_t>()((uint64_t(uint32_t(c.position)) << 32) ^
                                 (uint64_t(uint32_t(c.normal)) << 16) ^ uint32_t(c.uv));
  }
};

class ObjMeshBuilder {
 public:
  ObjMeshBuilder(const std::filesystem::path& path, const tinyobj::attrib_t& attrib)
      : path_(path), attrib_(attrib) {}

  // First pass: every index in range, and whether all corners carry normals and texcoords
  // (a mesh has them for all vertices or none).
  absl::Status check(const std::vector<tinyobj::shape_t>& shapes) {
    const int positions = static_cast<int>(attrib_.vertices.size() / 3);
    const int normals = static_cast<int>(attrib_.normals.size() / 3);
    const int uvs = static_cast<int>(attrib_.texcoords.size() / 2);
    size_t face = 0;
    for (const tinyobj::shape_t& shape : shapes) {
      // tinyobj keeps these in step; checked so that a surprise cannot turn into a bad read.
      if (shape.mesh.material_ids.size() != shape.mesh.num_face_vertices.size()) {
        return absl::InternalError(absl::StrCat(path_.string(), ": inconsistent tinyobj output"));
      }
      size_t corner_total = 0;
      for (const unsigned char corners : shape.mesh.num_face_vertices) corner_total += corners;
      if (corner_total != shape.mesh.indices.size()) return long_face_error(path_);
      size_t offset = 0;
      for (const unsigned char corners : shape.mesh.num_face_vertices) {
        if (offset + corners > shape.mesh.indices.size()) {
          return absl::InternalError(absl::StrCat(path_.string(), ": inconsistent tinyobj output"));
        }
        if (corners < 3) {
          return face_error(
              face, absl::StrCat("face has ", int{corners}, " vertices; a face needs at least 3"));
        }
        for (size_t k = 0; k < corners; ++k) {
          const tinyobj::index_t& index = shape.mesh.indices[offset + k];
          if (index.vertex_index < 0 || index.vertex_index >= positions) {
            return face_error(
                face, absl::StrCat("vertex index ", index.vertex_index + 1,
                                   " is out of range (the file has ", positions, " vertices)"));
          }
          if (index.normal_index >= normals || index.texcoord_index >= uvs) {
            return face_error(face, "normal or texture coordinate index is out of range");
          }
          all_normals_ = all_normals_ && index.normal_index >= 0;
          all_uvs_ = all_uvs_ && index.texcoord_index >= 0;
        }
        offset += corners;
        triangles_ += corners - 2;
        ++face;
      }
    }
    if (triangles_ > kMaxTrianglesPerMesh) {
      return absl::InvalidArgumentError(absl::StrCat(path_.string(), ": ", triangles_,
                                                     " triangles exceed the limit of ",
                                                     kMaxTrianglesPerMesh));
    }
    return absl::OkStatus();
  }

  Mesh build(const std::vector<tinyobj::shape_t>& shapes, size_t material_count) {
    Mesh mesh;
    mesh.name = path_.filename().string();
    mesh.indices.reserve(3 * triangles_);
    mesh.material_ids.reserve(triangles_);
    // Without per-corner attributes the OBJ positions are the vertices, as they are.
    const bool share_positions = !all_normals_ && !all_uvs_;
    if (share_positions) {
      mesh.positions.reserve(attrib_.vertices.size() / 3);
      for (size_t v = 0; v + 2 < attrib_.vertices.size(); v += 3) {
        mesh.positions.push_back(to_vec3(&attrib_.vertices[v]));
      }
    }
    std::vector<uint32_t> polygon;
    for (const tinyobj::shape_t& shape : shapes) {
      size_t offset = 0;
      for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
        const size_t corners = shape.mesh.num_face_vertices[f];
        polygon.clear();
        for (size_t k = 0; k < corners; ++k) {
          const tinyobj::index_t& index = shape.mesh.indices[offset + k];
          polygon.push_back(share_positions ? static_cast<uint32_t>(index.vertex_index)
                                            : vertex_for(index, &mesh));
        }
        offset += corners;
        const int id = shape.mesh.material_ids[f];
        const uint32_t material =
            id >= 0 && static_cast<size_t>(id) < material_count ? id : kNoMaterial;
        for (size_t k = 1; k + 1 < corners; ++k) {
          mesh.indices.insert(mesh.indices.end(), {polygon[0], polygon[k], polygon[k + 1]});
          mesh.material_ids.push_back(material);
        }
      }
    }
    return mesh;
  }

 private:
  absl::Status face_error(size_t face, absl::string_view message) const {
    return absl::InvalidArgumentError(
        absl::StrCat(path_.string(), ":", face_line(path_, face), ": face ", face, ": ", message));
  }

  uint32_t vertex_for(const tinyobj::index_t& index, Mesh* mesh) {
    const Corner corner{index.vertex_index, all_normals_ ? index.normal_index : -1,
                        all_uvs_ ? index.texcoord_index : -1};
    const auto [it, inserted] =
        vertex_of_corner_.try_emplace(corner, static_cast<uint32_t>(mesh->positions.size()));
    if (inserted) {
      mesh->positions.push_back(to_vec3(&attrib_.vertices[3 * size_t(corner.position)]));
      if (all_normals_)
        mesh->normals.push_back(to_vec3(&attrib_.normals[3 * size_t(corner.normal)]));
      if (all_uvs_) {
        const tinyobj::real_t* uv = &attrib_.texcoords[2 * size_t(corner.uv)];
        mesh->uvs.push_back({uv[0], 1.0f - uv[1]});  // v down the image, as glTF's
      }
    }
    return it->second;
  }

  const std::filesystem::path& path_;
  const tinyobj::attrib_t& attrib_;
  bool all_normals_ = true;
  bool all_uvs_ = true;
  size_t triangles_ = 0;
  std::unordered_map<Corner, uint32_t, CornerHash> vertex_of_corner_;
};

}  // namespace

absl::StatusOr<MeshFile> load_obj(const std::filesystem::path& path) {
  if (absl::Status file = check_regular_file(path); !file.ok()) return file;
  tinyobj::ObjReaderConfig config;
  config.triangulate = false;  // we fan polygons ourselves, keeping face numbers for errors
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  bool parsed = false;
  try {
    parsed = reader.ParseFromFile(path.string(), config);
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": ", e.what()));
  }
  if (!parsed) {
    // tinyobj's messages carry the line ("... line 5.)"); trailing newlines are noise.
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": ", absl::StripTrailingAsciiWhitespace(reader.Error())));
  }

  MeshFile file;
  const std::vector<tinyobj::material_t>& materials = reader.GetMaterials();
  TextureTable textures(path);
  for (size_t i = 0; i < materials.size(); ++i) {
    Material m = convert_material(materials[i], i, path.filename().string(), file.warnings);
    m.color_map = convert_map(materials[i].diffuse_texname, materials[i].diffuse_texopt, textures,
                              file.warnings);
    m.emission_map = convert_map(materials[i].emissive_texname, materials[i].emissive_texopt,
                                 textures, file.warnings);
    // `norm` names a tangent-space normal map; `bump` a height map, scaled by its -bm, from which
    // one is derived where `norm` is not given.
    m.normal_map = convert_map(materials[i].normal_texname, materials[i].normal_texopt, textures,
                               file.warnings);
    m.bump_map =
        convert_map(materials[i].bump_texname, materials[i].bump_texopt, textures, file.warnings);
    if (m.bump_map.used()) m.bump_scale = float(materials[i].bump_texopt.bump_multiplier);
    // The PBR extension's maps: one image named by both is packed as glTF packs it (roughness in
    // green, metalness in blue); two images are each read by their first channel.
    const tinyobj::material_t& mtl = materials[i];
    if (m.type == MaterialType::kMetallicRoughness) {
      if (mtl.roughness_texname == mtl.metallic_texname) {
        m.metallic_roughness_map =
            convert_map(mtl.roughness_texname, mtl.roughness_texopt, textures, file.warnings);
      } else {
        m.roughness_map =
            convert_map(mtl.roughness_texname, mtl.roughness_texopt, textures, file.warnings);
        m.metallic_map =
            convert_map(mtl.metallic_texname, mtl.metallic_texopt, textures, file.warnings);
        if (m.roughness_map.used() && m.metallic_map.used() &&
            !m.roughness_map.samples_like(m.metallic_map)) {
          file.warnings.push_back(absl::StrCat(
              path.filename().string(), ": material '", m.name, "': map_Pm '", mtl.metallic_texname,
              "' is not read: its -o, -s or -clamp differ from map_Pr's, with which it would be "
              "packed into one map; Pm ",
              m.metallic, " is used"));
          m.metallic_map = TextureRef{};
        }
      }
    }
    // `map_d` dissolves the surface where it is dark: the chance that a ray stops there.
    m.opacity_map =
        convert_map(materials[i].alpha_texname, materials[i].alpha_texopt, textures, file.warnings);
    if (m.opacity_map.used()) m.alpha_mode = AlphaMode::kBlend;
    file.materials.push_back(std::move(m));
  }
  warn_of_unread_maps(materials, path.filename().string(), file.warnings);
  file.textures = textures.take();
  ObjMeshBuilder builder(path, reader.GetAttrib());
  SCENE_RETURN_IF_ERROR(builder.check(reader.GetShapes()));
  file.meshes.push_back(builder.build(reader.GetShapes(), materials.size()));
  return file;
}

}  // namespace caustica
