#include "renderer/scene/mesh_ply.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "renderer/scene/file_io.h"
#include "renderer/scene/mesh_file.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/status_util.h"

namespace caustica {
namespace {

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };
enum class PlyType : uint8_t {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kFloat32,
  kFloat64
};

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  // for lists: the type of the items
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  size_t line = 0;  // header line that declared it
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  size_t body_offset = 0;      // first byte after the end_header line
  size_t body_first_line = 0;  // line number of that byte, for ascii errors
  std::vector<std::string> warnings;  // header lines skipped
};

std::optional<PlyType> parse_type(absl::string_view name) {
  // Both the original names and the sized aliases that newer writers use.
  static constexpr std::pair<absl::string_view, PlyType> kTypes[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [type_name, type] : kTypes) {
    if (name == type_name) return type;
  }
  return std::nullopt;
}

size_t type_size(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 1;
}

bool is_integer(PlyType type) { return type != PlyType::kFloat32 && type != PlyType::kFloat64; }

// Range of an integer type, for checking ascii values.
std::pair<int64_t, int64_t> integer_range(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
      return {INT8_MIN, INT8_MAX};
    case PlyType::kUint8:
      return {0, UINT8_MAX};
    case PlyType::kInt16:
      return {INT16_MIN, INT16_MAX};
    case PlyType::kUint16:
      return {0, UINT16_MAX};
    case PlyType::kInt32:
      return {INT32_MIN, INT32_MAX};
    default:
      return {0, UINT32_MAX};
  }
}

// ---------------------------------------------------------------------------------------------
// Header

class HeaderParser {
 public:
  HeaderParser(absl::string_view bytes, absl::string_view name) : bytes_(bytes), name_(name) {}

  absl::StatusOr<PlyHeader> parse() {
    absl::string_view line;
    // Some writers pad header lines with blanks, the magic line included.
    if (!next_line(&line) || absl::StripAsciiWhitespace(line) != "ply") {
      return error("not a PLY file (no 'ply' magic line)");
    }
    bool has_format = false;
    while (true) {
      if (!next_line(&line)) return error("header has no end_header line");
      const std::vector<absl::string_view> words =
          absl::StrSplit(line, absl::ByAnyChar(" \t"), absl::SkipEmpty());
      if (words.empty()) continue;
      const absl::string_view keyword = words[0];
      if (keyword == "end_header") break;
      if (keyword == "comment" || keyword == "obj_info") continue;
      if (keyword == "format") {
        SCENE_RETURN_IF_ERROR(parse_format(words));
        has_format = true;
      } else if (keyword == "element") {
        SCENE_RETURN_IF_ERROR(parse_element(words));
      } else if (keyword == "property") {
        SCENE_RETURN_IF_ERROR(parse_property(words));
      } else {
        // A line of free text where a comment belongs (Blender's "Created by Blender3D ..."):
        // MeshLab and Assimp skip it too.
        header_.warnings.push_back(absl::StrCat(
            name_, ":", line_number_, ": header line '", absl::StripAsciiWhitespace(line),
            "' starts with no PLY keyword; skipped as a comment"));
      }
    }
    if (!has_format) return error("header has no format line");
    header_.body_offset = offset_;
    header_.body_first_line = line_number_ + 1;
    return std::move(header_);
  }

 private:
  // Header lines end in "\n" or "\r\n"; the body starts right after end_header's newline.
  bool next_line(absl::string_view* line) {
    if (offset_ >= bytes_.size()) return false;
    size_t end = bytes_.find('\n', offset_);
    const bool has_newline = end != absl::string_view::npos;
    if (!has_newline) end = bytes_.size();
    *line = bytes_.substr(offset_, end - offset_);
    if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
    offset_ = has_newline ? end + 1 : end;
    ++line_number_;
    return true;
  }

  absl::Status error(absl::string_view message) const {
    return absl::InvalidArgumentError(absl::StrCat(name_, ":", line_number_, ": ", message));
  }

  absl::Status parse_format(const std::vector<absl::string_view>& words) {
    if (words.size() != 3 || words[2] != "1.0") {
      return error("expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
    }
    if (words[1] == "ascii") {
      header_.format = PlyFormat::kAscii;
    } else if (words[1] == "binary_little_endian") {
      header_.format = PlyFormat::kBinaryLittleEndian;
    } else if (words[1] == "binary_big_endian") {
      header_.format = PlyFormat::kBinaryBigEndian;
    } else {
      return error(absl::StrCat("unknown format '", words[1], "'"));
    }
    return absl::OkStatus();
  }

  absl::Status parse_element(const std::vector<absl::string_view>& words) {
    if (words.size() != 3) return error("expected 'element <name> <count>'");
    PlyElement element;
    element.name = std::string(words[1]);
    element.line = line_number_;
    const absl::string_view count = words[2];
    const auto [end, ec] =
        std::from_chars(count.data(), count.data() + count.size(), element.count);
    if (ec != std::errc() || end != count.data() + count.size()) {
      return error(absl::StrCat("element count '", count, "' is not a non-negative integer"));
    }
    for (const PlyElement& other : header_.elements) {
      if (other.name == element.name) {
        return error(absl::StrCat("element '", element.name, "' is declared twice"));
      }
    }
    header_.elements.push_back(std::move(element));
    return absl::OkStatus();
  }

  absl::Status parse_property(const std::vector<absl::string_view>& words) {
    if (header_.elements.empty()) return error("property before any element");
    PlyProperty property;
    if (words.size() == 5 && words[1] == "list") {
      const std::optional<PlyType> count_type = parse_type(words[2]);
      const std::optional<PlyType> item_type = parse_type(words[3]);
      if (!count_type || !item_type) {
        return error(absl::StrCat("unknown type in list property '", words[4], "'"));
      }
      property.is_list = true;
      property.count_type = *count_type;
      property.type = *item_type;
      property.name = std::string(words[4]);
    } else if (words.size() == 3) {
      const std::optional<PlyType> type = parse_type(words[1]);
      if (!type) return error(absl::StrCat("unknown property type '", words[1], "'"));
      property.type = *type;
      property.name = std::string(words[2]);
    } else {
      return error("expected 'property <type> <name>' or 'property list <type> <type> <name>'");
    }
    header_.elements.back().properties.push_back(std::move(property));
    return absl::OkStatus();
  }

  absl::string_view bytes_;
  absl::string_view name_;
  size_t offset_ = 0;
  size_t line_number_ = 0;
  PlyHeader header_;
};

// ---------------------------------------------------------------------------------------------
// Body readers. Both return values as double (exact for every PLY integer type) and, on failure,
// leave a description of the problem; the body parser adds which element and property it was.

// ascii bodies hold one element instance per line, values separated by blanks.
class AsciiReader {
 public:
  AsciiReader(absl::string_view text, size_t first_line, absl::string_view name)
      : text_(text), line_(first_line), name_(name) {}

  bool begin_instance() {
    while (pos_ < text_.size() && is_blank_or_newline(text_[pos_])) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    value_line_ = line_;
    if (pos_ < text_.size()) return true;
    problem_ = "data ends early (file truncated?)";
    return false;
  }

  bool read(PlyType type, double* value) {
    while (pos_ < text_.size() && is_blank(text_[pos_])) ++pos_;
    value_line_ = line_;
    size_t end = pos_;
    while (end < text_.size() && !is_blank_or_newline(text_[end])) ++end;
    const absl::string_view token = text_.substr(pos_, end - pos_);
    if (token.empty()) {
      problem_ = "line has too few values";
      return false;
    }
    pos_ = end;
    return is_integer(type) ? parse_integer(token, type, value) : parse_float(token, value);
  }

  // Each list item takes at least one character, so a corrupt count fails here, not after
  // reading the rest of the file as one list.
  bool can_hold(double items, PlyType) {
    if (items <= double(text_.size() - pos_)) return true;
    problem_ = absl::StrCat("list of ", items, " items runs past the end of the data");
    return false;
  }

  bool end_instance() {
    while (pos_ < text_.size() && is_blank(text_[pos_])) ++pos_;
    if (pos_ >= text_.size() || text_[pos_] == '\n') return true;
    value_line_ = line_;
    problem_ = "line has more values than the header declares";
    return false;
  }

  size_t bytes_left() const { return text_.size() - pos_; }

  // `message` located at the value last read.
  absl::Status error_here(absl::string_view message) const {
    return absl::InvalidArgumentError(absl::StrCat(name_, ":", value_line_, ": ", message));
  }
  // The reader's own problem with the value last read, in `context`.
  absl::Status error(absl::string_view context) const {
    return error_here(absl::StrCat(context, ": ", problem_));
  }

 private:
  static bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }
  static bool is_blank_or_newline(char c) { return is_blank(c) || c == '\n'; }

  bool parse_integer(absl::string_view token, PlyType type, double* value) {
    int64_t v = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
    const auto [lo, hi] = integer_range(type);
    if (ec != std::errc() || end != token.data() + token.size() || v < lo || v > hi) {
      problem_ = absl::StrCat("'", token, "' is not an integer in [", lo, ", ", hi, "]");
      return false;
    }
    *value = static_cast<double>(v);
    return true;
  }

  bool parse_float(absl::string_view token, double* value) {
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *value);
    if (ec != std::errc() || end != token.data() + token.size()) {
      problem_ = absl::StrCat("'", token, "' is not a number");
      return false;
    }
    return true;
  }

  absl::string_view text_;
  size_t pos_ = 0;
  size_t line_;
  size_t value_line_ = 0;
  absl::string_view name_;
  std::string problem_;
};

class BinaryReader {
 public:
  BinaryReader(absl::string_view bytes, size_t offset, bool big_endian, absl::string_view name)
      : bytes_(bytes),
        pos_(offset),
        swap_(big_endian != (std::endian::native == std::endian::big)),
        name_(name) {}

  bool begin_instance() { return true; }
  bool end_instance() { return true; }

  bool read(PlyType type, double* value) {
    value_offset_ = pos_;
    const size_t size = type_size(type);
    if (bytes_.size() - pos_ < size) {
      problem_ = "data ends early (file truncated?)";
      return false;
    }
    std::array<unsigned char, 8> raw;
    std::memcpy(raw.data(), bytes_.data() + pos_, size);
    if (swap_) std::reverse(raw.begin(), raw.begin() + size);
    pos_ += size;
    *value = decode(type, raw.data());
    return true;
  }

  // Checked before a list is read, so that a corrupt count cannot make us loop for billions of
  // items that are not there.
  bool can_hold(double items, PlyType type) {
    value_offset_ = pos_;
    if (items * double(type_size(type)) <= double(bytes_.size() - pos_)) return true;
    problem_ =
        absl::StrCat("list of ", items, " items runs past the end of the data (file truncated?)");
    return false;
  }

  size_t bytes_left() const { return bytes_.size() - pos_; }

  absl::Status error_here(absl::string_view message) const {
    return absl::InvalidArgumentError(
        absl::StrCat(name_, ": at byte ", value_offset_, ": ", message));
  }
  absl::Status error(absl::string_view context) const {
    return error_here(absl::StrCat(context, ": ", problem_));
  }

 private:
  template <typename T>
  static double load(const unsigned char* raw) {
    T v;
    std::memcpy(&v, raw, sizeof(T));
    return static_cast<double>(v);
  }

  static double decode(PlyType type, const unsigned char* raw) {
    switch (type) {
      case PlyType::kInt8:
        return load<int8_t>(raw);
      case PlyType::kUint8:
        return load<uint8_t>(raw);
      case PlyType::kInt16:
        return load<int16_t>(raw);
      case PlyType::kUint16:
        return load<uint16_t>(raw);
      case PlyType::kInt32:
        return load<int32_t>(raw);
      case PlyType::kUint32:
        return load<uint32_t>(raw);
      case PlyType::kFloat32:
        return load<float>(raw);
      case PlyType::kFloat64:
        return load<double>(raw);
    }
    return 0;
  }

  absl::string_view bytes_;
  size_t pos_;
  size_t value_offset_ = 0;
  bool swap_;
  absl::string_view name_;
  std::string problem_;
};

// ---------------------------------------------------------------------------------------------
// Body

// What a vertex property feeds; indices into a vertex's 8 slots.
enum VertexSlot : int { kX, kY, kZ, kNx, kNy, kNz, kU, kV, kSlotCount, kUnused = -1 };

struct VertexLayout {
  std::vector<int> slot_of_property;  // kUnused for properties we skip
  bool has_normals = false;
  bool has_uvs = false;
};

absl::StatusOr<VertexLayout> vertex_layout(const PlyElement& element, absl::string_view name) {
  VertexLayout layout;
  std::array<bool, kSlotCount> present{};
  for (const PlyProperty& property : element.properties) {
    static constexpr std::pair<absl::string_view, int> kNames[] = {
        {"x", kX},         {"y", kY},         {"z", kZ},         {"nx", kNx},      {"ny", kNy},
        {"nz", kNz},       {"u", kU},         {"v", kV},         {"s", kU},        {"t", kV},
        {"texture_u", kU}, {"texture_v", kV}, {"texture_s", kU}, {"texture_t", kV}};
    int slot = kUnused;
    for (const auto& [property_name, property_slot] : kNames) {
      if (property.name == property_name && !property.is_list) slot = property_slot;
    }
    if (slot != kUnused && present[slot]) slot = kUnused;  // first of u/s/texture_u wins
    if (slot != kUnused) present[slot] = true;
    layout.slot_of_property.push_back(slot);
  }
  if (!present[kX] || !present[kY] || !present[kZ]) {
    return absl::InvalidArgumentError(absl::StrCat(
        name, ":", element.line, ": element 'vertex' lacks one of the properties x, y, z"));
  }
  layout.has_normals = present[kNx] && present[kNy] && present[kNz];
  layout.has_uvs = present[kU] && present[kV];
  return layout;
}

const PlyElement* find_element(const PlyHeader& header, absl::string_view element_name) {
  for (const PlyElement& element : header.elements) {
    if (element.name == element_name) return &element;
  }
  return nullptr;
}

// Index of the face list property, which some writers call vertex_index.
std::optional<size_t> face_list_property(const PlyElement& face) {
  for (size_t p = 0; p < face.properties.size(); ++p) {
    const PlyProperty& property = face.properties[p];
    if (property.is_list &&
        (property.name == "vertex_indices" || property.name == "vertex_index")) {
      return p;
    }
  }
  return std::nullopt;
}

template <typename Reader>
class BodyParser {
 public:
  BodyParser(Reader& reader, const PlyHeader& header, absl::string_view name, Mesh* mesh)
      : reader_(reader), header_(header), name_(name), mesh_(mesh) {}

  absl::Status parse() {
    const PlyElement* vertex = find_element(header_, "vertex");
    const PlyElement* face = find_element(header_, "face");
    if (vertex == nullptr) return header_error("no 'vertex' element");
    if (face == nullptr) {
      return header_error("no 'face' element: a point cloud has no surface to render");
    }
    if (vertex->count > kMaxVerticesPerMesh) {
      return element_error(*vertex, absl::StrCat(vertex->count, " vertices exceed the limit of ",
                                                 kMaxVerticesPerMesh));
    }
    // Every face gives at least one triangle.
    if (face->count > kMaxTrianglesPerMesh) {
      return element_error(*face, absl::StrCat(face->count, " faces exceed the limit of ",
                                               kMaxTrianglesPerMesh, " triangles"));
    }
    SCENE_ASSIGN_OR_RETURN(layout_, vertex_layout(*vertex, name_));
    face_list_ = face_list_property(*face);
    if (!face_list_) {
      return element_error(*face, "element 'face' has no list property 'vertex_indices'");
    }
    vertex_count_ = vertex->count;

    for (const PlyElement& element : header_.elements) {
      if (&element == vertex) {
        SCENE_RETURN_IF_ERROR(read_vertices(element));
      } else if (&element == face) {
        SCENE_RETURN_IF_ERROR(read_faces(element));
      } else {
        SCENE_RETURN_IF_ERROR(skip_element(element));
      }
    }
    mesh_->material_ids.assign(mesh_->triangle_count(), kNoMaterial);
    return absl::OkStatus();
  }

 private:
  absl::Status header_error(absl::string_view message) const {
    return absl::InvalidArgumentError(absl::StrCat(name_, ": PLY header: ", message));
  }
  absl::Status element_error(const PlyElement& element, absl::string_view message) const {
    return absl::InvalidArgumentError(absl::StrCat(name_, ":", element.line, ": ", message));
  }

  // Each instance takes at least one byte, so this bounds reservations by the data really there.
  size_t plausible_count(uint64_t count) const {
    return static_cast<size_t>(std::min<uint64_t>(count, reader_.bytes_left()));
  }

  std::string where(const PlyElement& element, uint64_t index, const PlyProperty& property) const {
    return absl::StrCat(element.name, " ", index, ", property '", property.name, "'");
  }

  absl::Status read_list_count(const PlyElement& element, uint64_t index,
                               const PlyProperty& property, uint64_t* count) {
    double value = 0;
    if (!reader_.read(property.count_type, &value)) {
      return reader_.error(where(element, index, property));
    }
    // A float-typed count is legal PLY but must still be a whole number.
    if (!(value >= 0) || value != std::floor(value)) {
      return reader_.error_here(absl::StrCat(where(element, index, property), ": list count ",
                                             value, " is not a non-negative integer"));
    }
    if (!reader_.can_hold(value, property.type)) {
      return reader_.error(where(element, index, property));
    }
    *count = static_cast<uint64_t>(value);
    return absl::OkStatus();
  }

  absl::Status read_vertices(const PlyElement& element) {
    mesh_->positions.reserve(plausible_count(element.count));
    if (layout_.has_normals) mesh_->normals.reserve(plausible_count(element.count));
    if (layout_.has_uvs) mesh_->uvs.reserve(plausible_count(element.count));
    std::array<double, kSlotCount> slots{};
    for (uint64_t i = 0; i < element.count; ++i) {
      if (!reader_.begin_instance()) return reader_.error(absl::StrCat("vertex ", i));
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        if (property.is_list) {
          SCENE_RETURN_IF_ERROR(skip_list(element, i, property));
          continue;
        }
        double value = 0;
        if (!reader_.read(property.type, &value)) {
          return reader_.error(where(element, i, property));
        }
        if (const int slot = layout_.slot_of_property[p]; slot != kUnused) slots[slot] = value;
      }
      if (!reader_.end_instance()) return reader_.error(absl::StrCat("vertex ", i));
      mesh_->positions.push_back(to_vec3(slots[kX], slots[kY], slots[kZ]));
      if (layout_.has_normals)
        mesh_->normals.push_back(to_vec3(slots[kNx], slots[kNy], slots[kNz]));
      if (layout_.has_uvs) {
        // PLY writers (Blender, MeshLab) put v up the image, the scene down it (glTF's).
        mesh_->uvs.push_back({static_cast<float>(slots[kU]), 1.0f - static_cast<float>(slots[kV])});
      }
    }
    return absl::OkStatus();
  }

  absl::Status read_faces(const PlyElement& element) {
    mesh_->indices.reserve(3 * plausible_count(element.count));
    std::vector<uint32_t> polygon;
    for (uint64_t i = 0; i < element.count; ++i) {
      if (!reader_.begin_instance()) return reader_.error(absl::StrCat("face ", i));
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        if (p != *face_list_) {
          SCENE_RETURN_IF_ERROR(property.is_list ? skip_list(element, i, property)
                                                 : skip_value(element, i, property));
          continue;
        }
        SCENE_RETURN_IF_ERROR(read_polygon(element, i, property, &polygon));
        if (polygon.size() < 3) {
          return reader_.error_here(absl::StrCat("face ", i, " has ", polygon.size(),
                                                 " vertices; a face needs at least 3"));
        }
        for (size_t k = 1; k + 1 < polygon.size(); ++k) {
          mesh_->indices.insert(mesh_->indices.end(), {polygon[0], polygon[k], polygon[k + 1]});
        }
        if (mesh_->triangle_count() > kMaxTrianglesPerMesh) {
          return reader_.error_here(
              absl::StrCat("face ", i, ": the mesh exceeds ", kMaxTrianglesPerMesh, " triangles"));
        }
      }
      if (!reader_.end_instance()) return reader_.error(absl::StrCat("face ", i));
    }
    return absl::OkStatus();
  }

  absl::Status read_polygon(const PlyElement& element, uint64_t index, const PlyProperty& property,
                            std::vector<uint32_t>* polygon) {
    uint64_t count = 0;
    SCENE_RETURN_IF_ERROR(read_list_count(element, index, property, &count));
    polygon->clear();
    for (uint64_t k = 0; k < count; ++k) {
      double value = 0;
      if (!reader_.read(property.type, &value)) {
        return reader_.error(where(element, index, property));
      }
      if (!(value >= 0 && value < double(vertex_count_)) || value != std::floor(value)) {
        return reader_.error_here(absl::StrCat("face ", index, ": vertex index ", value,
                                               " is out of range (the file has ", vertex_count_,
                                               " vertices)"));
      }
      polygon->push_back(static_cast<uint32_t>(value));
    }
    return absl::OkStatus();
  }

  absl::Status skip_value(const PlyElement& element, uint64_t index, const PlyProperty& property) {
    double ignored = 0;
    if (!reader_.read(property.type, &ignored))
      return reader_.error(where(element, index, property));
    return absl::OkStatus();
  }

  absl::Status skip_list(const PlyElement& element, uint64_t index, const PlyProperty& property) {
    uint64_t count = 0;
    SCENE_RETURN_IF_ERROR(read_list_count(element, index, property, &count));
    for (uint64_t k = 0; k < count; ++k) {
      SCENE_RETURN_IF_ERROR(skip_value(element, index, property));
    }
    return absl::OkStatus();
  }

  absl::Status skip_element(const PlyElement& element) {
    // Instances without properties hold no data, and a huge count of them must not spin.
    if (element.properties.empty()) return absl::OkStatus();
    for (uint64_t i = 0; i < element.count; ++i) {
      if (!reader_.begin_instance()) return reader_.error(absl::StrCat(element.name, " ", i));
      for (const PlyProperty& property : element.properties) {
        SCENE_RETURN_IF_ERROR(property.is_list ? skip_list(element, i, property)
                                               : skip_value(element, i, property));
      }
      if (!reader_.end_instance()) return reader_.error(absl::StrCat(element.name, " ", i));
    }
    return absl::OkStatus();
  }

  static Vec3f to_vec3(double x, double y, double z) {
    return {static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)};
  }

  Reader& reader_;
  const PlyHeader& header_;
  absl::string_view name_;
  Mesh* mesh_;
  VertexLayout layout_;
  std::optional<size_t> face_list_;
  uint64_t vertex_count_ = 0;
};

}  // namespace

absl::StatusOr<Mesh> parse_ply(absl::string_view bytes, absl::string_view name,
                               std::vector<std::string>* warnings) {
  SCENE_ASSIGN_OR_RETURN(const PlyHeader header, HeaderParser(bytes, name).parse());
  if (warnings != nullptr)
    warnings->insert(warnings->end(), header.warnings.begin(), header.warnings.end());
  Mesh mesh;
  mesh.name = std::string(name);
  if (header.format == PlyFormat::kAscii) {
    AsciiReader reader(bytes.substr(header.body_offset), header.body_first_line, name);
    SCENE_RETURN_IF_ERROR(BodyParser<AsciiReader>(reader, header, name, &mesh).parse());
  } else {
    BinaryReader reader(bytes, header.body_offset, header.format == PlyFormat::kBinaryBigEndian,
                        name);
    SCENE_RETURN_IF_ERROR(BodyParser<BinaryReader>(reader, header, name, &mesh).parse());
  }
  return mesh;
}

absl::StatusOr<Mesh> load_ply(const std::filesystem::path& path,
                              std::vector<std::string>* warnings) {
  SCENE_ASSIGN_OR_RETURN(const std::string bytes, read_file(path));
  SCENE_ASSIGN_OR_RETURN(Mesh mesh, parse_ply(bytes, path.string(), warnings));
  mesh.name = path.filename().string();
  return mesh;
}

}  // namespace caustica
