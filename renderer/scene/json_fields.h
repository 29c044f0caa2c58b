// Reading JSON scene fields together with their paths, so that every error can say exactly which
// field is wrong ("shapes[3].vertices[2]: expected [x, y, z] ...") and leftover keys (typos) are
// reported instead of silently ignored. The scene module's, and the client's for its scripts.
#pragma once

#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "renderer/base/vec.h"
#include "renderer/scene/affine.h"
#include "renderer/scene/status_util.h"

namespace caustica {

using Json = nlohmann::json;

enum class Presence { kRequired, kOptional };

// "path[i]": the path of an array element.
std::string element_path(absl::string_view array_path, size_t index);

// Conversions of one value; `path` names the value in errors.
absl::StatusOr<float> json_to_float(const Json& value, absl::string_view path);  // finite float
absl::StatusOr<int64_t> json_to_integer(const Json& value, absl::string_view path, int64_t lo,
                                        int64_t hi);
absl::StatusOr<Vec3f> json_to_vec3(const Json& value, absl::string_view path);
absl::StatusOr<std::string> json_to_string(const Json& value, absl::string_view path);
// Fails unless `value` is an array.
absl::Status json_expect_array(const Json& value, absl::string_view path);
// A "transform" object, {"translate": [x, y, z], "rotate": [x, y, z], "scale": s or [x, y, z]},
// every key optional, as transform.h's placement() makes it.
absl::StatusOr<Affine> read_transform(const Json& value, std::string path);

// One JSON object being read field by field.
class JsonObject {
 public:
  // Fails unless `value` is an object. `value` must outlive the JsonObject.
  static absl::StatusOr<JsonObject> open(const Json& value, std::string path);

  const std::string& path() const { return path_; }
  std::string field_path(absl::string_view key) const;

  // The value of `key`, or null when it is absent and optional. Marks `key` as known.
  absl::StatusOr<const Json*> find(absl::string_view key, Presence presence);
  bool has(absl::string_view key);  // also marks `key` as known

  // Typed reads. An absent optional key leaves *out as it was (its default).
  absl::Status read(absl::string_view key, Presence presence, float* out);
  absl::Status read(absl::string_view key, Presence presence, Vec3f* out);
  absl::Status read(absl::string_view key, Presence presence, std::string* out);
  absl::Status read(absl::string_view key, Presence presence, bool* out);
  template <typename Int>
  absl::Status read_integer(absl::string_view key, Presence presence, Int* out,
                            int64_t lo = std::numeric_limits<Int>::min(),
                            int64_t hi = std::numeric_limits<Int>::max()) {
    SCENE_ASSIGN_OR_RETURN(const Json* value, find(key, presence));
    if (value == nullptr) return absl::OkStatus();
    SCENE_ASSIGN_OR_RETURN(const int64_t v, json_to_integer(*value, field_path(key), lo, hi));
    *out = static_cast<Int>(v);
    return absl::OkStatus();
  }

  // Fails on the first key that no find/has/read asked about, listing those that were.
  absl::Status finish() const;

 private:
  JsonObject(const Json& value, std::string path) : value_(&value), path_(std::move(path)) {}

  const Json* value_;
  std::string path_;
  std::vector<std::string> known_keys_;
};

}  // namespace caustica
