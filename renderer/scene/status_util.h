// absl::Status helpers of the scene module: early returns (renderer/base has none yet; prefixed so
// that they cannot clash with a shared set added later) and the two shapes its errors take.
#pragma once

#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

#define SCENE_STATUS_CONCAT_INNER(a, b) a##b
#define SCENE_STATUS_CONCAT(a, b) SCENE_STATUS_CONCAT_INNER(a, b)

#define SCENE_RETURN_IF_ERROR(expr)                                 \
  do {                                                              \
    if (absl::Status scene_status_ = (expr); !scene_status_.ok()) { \
      return scene_status_;                                         \
    }                                                               \
  } while (false)

#define SCENE_ASSIGN_OR_RETURN(lhs, expr) \
  SCENE_ASSIGN_OR_RETURN_IMPL(SCENE_STATUS_CONCAT(scene_statusor_, __LINE__), lhs, expr)

#define SCENE_ASSIGN_OR_RETURN_IMPL(statusor, lhs, expr)   \
  auto statusor = (expr);                                  \
  if (!statusor.ok()) return std::move(statusor).status(); \
  lhs = std::move(statusor).value()

namespace caustica {

// InvalidArgumentError "field: problem", where field is a JSON path like "shapes[3].vertices[2]"
// or another name a person can find in the input.
inline absl::Status invalid_field(absl::string_view field, absl::string_view problem) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", problem));
}

// Returns `status` with "context: " in front of its message and the same code, so that an error
// from deep inside a loader still says which file and field it came from.
inline absl::Status annotate(const absl::Status& status, absl::string_view context) {
  if (status.ok()) return status;
  return absl::Status(status.code(), absl::StrCat(context, ": ", status.message()));
}

}  // namespace caustica
