#include "renderer/scene/file_io.h"

#include <zlib.h>

#include <algorithm>
#include <memory>
#include <system_error>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "renderer/scene/scene_limits.h"

namespace caustica {
namespace {

struct GzFileCloser {
  void operator()(gzFile file) const { gzclose(file); }
};
using GzFile = std::unique_ptr<gzFile_s, GzFileCloser>;

// zlib takes chunk lengths as unsigned int; 4 MiB chunks keep the calls few without a big spike.
constexpr size_t kChunkBytes = size_t{4} << 20;
// zlib's input buffer for a large file, and its default for a small one.
constexpr uintmax_t kGzBufferBytes = 256 * 1024;
constexpr uintmax_t kMinGzBufferBytes = 8 * 1024;

}  // namespace

absl::Status check_regular_file(const std::filesystem::path& path) {
  // The error_code overload: the throwing one throws for a name too long.
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (status.type() == std::filesystem::file_type::not_found) {
    return absl::NotFoundError(absl::StrCat(path.string(), ": file not found"));
  }
  if (ec) {
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": cannot open file: ", ec.message()));
  }
  if (!std::filesystem::is_regular_file(status)) {
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": not a regular file"));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::string> read_file(const std::filesystem::path& path) {
  if (absl::Status file = check_regular_file(path); !file.ok()) return file;
  std::error_code ec;
  // gzread passes non-gzip files through, so one path serves .ply and .ply.gz alike.
  GzFile file(gzopen(path.c_str(), "rb"));
  if (file == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": cannot open file"));
  }
  // The on-disk size is exact for plain files and a lower bound for compressed ones. The first
  // read asks for that size and one byte more (to see the end), so that a small file costs a small
  // buffer rather than a zero-filled 4 MiB one; reads then double up to kChunkBytes. zlib's own
  // buffers (three times the size given here) grow with the file up to kGzBufferBytes, so that
  // reading a small file does not allocate most of a megabyte.
  const uintmax_t disk_size = std::filesystem::file_size(path, ec);
  gzbuffer(file.get(), static_cast<unsigned>(
                           ec ? kGzBufferBytes
                              : std::clamp<uintmax_t>(disk_size + 1, kMinGzBufferBytes,
                                                      kGzBufferBytes)));

  std::string bytes;
  size_t step = ec ? kChunkBytes
                   : static_cast<size_t>(std::clamp<uintmax_t>(disk_size + 1, 4096, kChunkBytes));
  size_t used = 0;
  while (true) {
    if (bytes.size() < used + step) bytes.resize(used + step);
    const int n = gzread(file.get(), bytes.data() + used, static_cast<unsigned>(step));
    if (n < 0) {
      // gzerror's text repeats the path, so only its code is used.
      int zerr = 0;
      gzerror(file.get(), &zerr);
      return absl::InvalidArgumentError(absl::StrCat(
          path.string(), zerr == Z_ERRNO ? ": cannot read file" : ": corrupt gzip data"));
    }
    used += static_cast<size_t>(n);
    if (n == 0) break;
    step = std::min(2 * step, kChunkBytes);
    if (used > kMaxFileBytes) {
      return absl::InvalidArgumentError(absl::StrCat(
          path.string(), ": file is larger than the limit of ", kMaxFileBytes, " bytes"));
    }
  }
  // A gzip stream cut short reads as a clean end of file; only gzerror tells the difference.
  int zerr = Z_OK;
  gzerror(file.get(), &zerr);
  if (zerr != Z_OK && zerr != Z_STREAM_END) {
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": corrupt or truncated gzip data"));
  }
  bytes.resize(used);
  return bytes;
}

}  // namespace caustica
