// Whole-file reads for the loaders. Scene and mesh files are small enough to hold in memory, and
// parsing from memory is both faster and simpler to bound-check than parsing from a stream.
#pragma once

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"

namespace caustica {

// Returns the bytes of `path`, inflated when the file is gzip-compressed (plain files pass
// through unchanged). NotFoundError when the file does not exist; errors name the path.
absl::StatusOr<std::string> read_file(const std::filesystem::path& path);

}  // namespace caustica
