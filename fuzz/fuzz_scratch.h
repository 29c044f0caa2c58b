// What the fuzz targets share: a scratch directory of the process's own for the loaders that
// read only from paths, and the check that ends a run on a broken loader contract.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>

namespace caustica::fuzz {

// A fresh directory under the temp directory (TMPDIR: scripts/fuzz points it at a directory of
// its own, on /dev/shm where there is one), named after the process so that parallel fuzzers never
// share files. Removed at a normal exit; after a crash it stays behind (scripts/fuzz removes its
// whole scratch space when it ends).
class ScratchDirectory {
 public:
  explicit ScratchDirectory(std::string_view target)
      : path_(std::filesystem::temp_directory_path() /
              ("caustica-fuzz-" + std::string(target) + "-" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDirectory() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;

  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Replaces the file at `path` with `bytes`. A failure here is the harness's, not the loader's, so
// it stops the run loudly instead of letting every later input test a missing file.
inline void write_file(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz harness: cannot write %s\n", path.c_str());
    std::abort();
  }
}

// A loader returned success with a result that breaks its documented contract: as much a bug as
// a crash, so it ends the run the same way (libFuzzer saves the input).
#define CAUSTICA_FUZZ_CHECK(condition, message)                                              \
  do {                                                                                       \
    if (!(condition)) {                                                                      \
      std::fprintf(stderr, "%s:%d: contract broken: %s (%s)\n", __FILE__, __LINE__, message, \
                   #condition);                                                              \
      std::abort();                                                                          \
    }                                                                                        \
  } while (false)

}  // namespace caustica::fuzz
