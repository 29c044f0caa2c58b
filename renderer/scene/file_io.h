// Whole-file reads for the loaders. Scene and mesh files are small enough to hold in memory, and
// parsing from memory is both faster and simpler to bound-check than parsing from a stream.
#pragma once

#include <filesystem>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace caustica {

// OK when `path` names a regular file; else NotFoundError when nothing is there, or an error with
// the system's reason (a name too long, a directory not searchable). Errors name the path.
absl::Status check_regular_file(const std::filesystem::path& path);

// Returns the bytes of `path`, inflated when the file is gzip-compressed (plain files pass
// through unchanged). NotFoundError when the file does not exist; errors name the path.
absl::StatusOr<std::string> read_file(const std::filesystem::path& path);

}  // namespace caustica
