#include "renderer/scene/json_fields.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "renderer/scene/transform.h"

namespace caustica {
namespace {

// A short rendering of what was found instead, for "expected X, got Y" messages.
std::string describe(const Json& value) {
  std::string text = value.dump();
  constexpr size_t kMaxChars = 40;
  if (text.size() > kMaxChars) text = absl::StrCat(text.substr(0, kMaxChars), "...");
  return absl::StrCat(value.type_name(), " ", text);
}

}  // namespace

std::string element_path(absl::string_view array_path, size_t index) {
  return absl::StrCat(array_path, "[", index, "]");
}

absl::StatusOr<float> json_to_float(const Json& value, absl::string_view path) {
  if (!value.is_number())
    return invalid_field(path, absl::StrCat("expected a number, got ", describe(value)));
  const double v = value.get<double>();
  if (!std::isfinite(v) || std::fabs(v) > FLT_MAX) {
    return invalid_field(path, absl::StrCat(value.dump(), " does not fit a 32-bit float"));
  }
  return static_cast<float>(v);
}

absl::StatusOr<int64_t> json_to_integer(const Json& value, absl::string_view path, int64_t lo,
                                        int64_t hi) {
  const std::string expected = absl::StrCat("expected an integer in [", lo, ", ", hi, "], got ");
  if (value.is_number_unsigned()) {
    const uint64_t v = value.get<uint64_t>();
    if (v > static_cast<uint64_t>(hi) || static_cast<int64_t>(v) < lo) {
      return invalid_field(path, absl::StrCat(expected, v));
    }
    return static_cast<int64_t>(v);
  }
  if (value.is_number_integer()) {
    const int64_t v = value.get<int64_t>();
    if (v < lo || v > hi) return invalid_field(path, absl::StrCat(expected, v));
    return v;
  }
  // Written as 1e6 or 512.0: fine when it is a whole number in range.
  if (value.is_number_float()) {
    const double v = value.get<double>();
    if (v == std::floor(v) && v >= static_cast<double>(lo) && v <= static_cast<double>(hi)) {
      return static_cast<int64_t>(v);
    }
  }
  return invalid_field(path, absl::StrCat(expected, describe(value)));
}

absl::StatusOr<Vec3f> json_to_vec3(const Json& value, absl::string_view path) {
  if (!value.is_array() || value.size() != 3) {
    return invalid_field(path,
                         absl::StrCat("expected [x, y, z] (3 numbers), got ", describe(value)));
  }
  Vec3f v;
  for (int i = 0; i < 3; ++i) {
    SCENE_ASSIGN_OR_RETURN(v[i], json_to_float(value[i], element_path(path, i)));
  }
  return v;
}

absl::StatusOr<std::string> json_to_string(const Json& value, absl::string_view path) {
  if (!value.is_string())
    return invalid_field(path, absl::StrCat("expected a string, got ", describe(value)));
  return value.get<std::string>();
}

absl::Status json_expect_array(const Json& value, absl::string_view path) {
  if (!value.is_array())
    return invalid_field(path, absl::StrCat("expected an array, got ", describe(value)));
  return absl::OkStatus();
}

absl::StatusOr<JsonObject> JsonObject::open(const Json& value, std::string path) {
  if (!value.is_object()) {
    return invalid_field(path.empty() ? "top level" : path,
                         absl::StrCat("expected an object, got ", describe(value)));
  }
  return JsonObject(value, std::move(path));
}

std::string JsonObject::field_path(absl::string_view key) const {
  return path_.empty() ? std::string(key) : absl::StrCat(path_, ".", key);
}

absl::StatusOr<const Json*> JsonObject::find(absl::string_view key, Presence presence) {
  if (std::find(known_keys_.begin(), known_keys_.end(), key) == known_keys_.end()) {
    known_keys_.emplace_back(key);
  }
  const auto it = value_->find(std::string(key));
  if (it != value_->end()) return &*it;
  if (presence == Presence::kRequired)
    return invalid_field(field_path(key), "is required but missing");
  return nullptr;
}

bool JsonObject::has(absl::string_view key) {
  const absl::StatusOr<const Json*> value = find(key, Presence::kOptional);
  return *value != nullptr;
}

absl::Status JsonObject::read(absl::string_view key, Presence presence, float* out) {
  SCENE_ASSIGN_OR_RETURN(const Json* value, find(key, presence));
  if (value == nullptr) return absl::OkStatus();
  SCENE_ASSIGN_OR_RETURN(*out, json_to_float(*value, field_path(key)));
  return absl::OkStatus();
}

absl::Status JsonObject::read(absl::string_view key, Presence presence, Vec3f* out) {
  SCENE_ASSIGN_OR_RETURN(const Json* value, find(key, presence));
  if (value == nullptr) return absl::OkStatus();
  SCENE_ASSIGN_OR_RETURN(*out, json_to_vec3(*value, field_path(key)));
  return absl::OkStatus();
}

absl::Status JsonObject::read(absl::string_view key, Presence presence, std::string* out) {
  SCENE_ASSIGN_OR_RETURN(const Json* value, find(key, presence));
  if (value == nullptr) return absl::OkStatus();
  SCENE_ASSIGN_OR_RETURN(*out, json_to_string(*value, field_path(key)));
  return absl::OkStatus();
}

absl::Status JsonObject::read(absl::string_view key, Presence presence, bool* out) {
  SCENE_ASSIGN_OR_RETURN(const Json* value, find(key, presence));
  if (value == nullptr) return absl::OkStatus();
  if (!value->is_boolean()) {
    return invalid_field(field_path(key),
                         absl::StrCat("expected true or false, got ", describe(*value)));
  }
  *out = value->get<bool>();
  return absl::OkStatus();
}

absl::Status JsonObject::finish() const {
  for (const auto& [key, unused] : value_->items()) {
    if (std::find(known_keys_.begin(), known_keys_.end(), key) == known_keys_.end()) {
      return invalid_field(
          field_path(key),
          absl::StrCat("unknown key (known keys here: ", absl::StrJoin(known_keys_, ", "), ")"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<Affine> read_transform(const Json& value, std::string path) {
  SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(value, std::move(path)));
  Vec3f scale{1, 1, 1}, rotate{0, 0, 0}, translate{0, 0, 0};
  SCENE_ASSIGN_OR_RETURN(const Json* scale_value, object.find("scale", Presence::kOptional));
  if (scale_value != nullptr && scale_value->is_number()) {
    SCENE_ASSIGN_OR_RETURN(const float s, json_to_float(*scale_value, object.field_path("scale")));
    scale = Vec3f(s);
  } else if (scale_value != nullptr) {
    SCENE_ASSIGN_OR_RETURN(scale, json_to_vec3(*scale_value, object.field_path("scale")));
  }
  if (scale.x == 0 || scale.y == 0 || scale.z == 0) {
    return invalid_field(object.field_path("scale"), "must not be zero: it would flatten the mesh");
  }
  SCENE_RETURN_IF_ERROR(object.read("rotate", Presence::kOptional, &rotate));
  SCENE_RETURN_IF_ERROR(object.read("translate", Presence::kOptional, &translate));
  SCENE_RETURN_IF_ERROR(object.finish());
  return placement(translate, rotate, scale);
}

}  // namespace caustica
