// The texture images one model file references, as its loader collects them: each image once,
// read from a file beside the model or taken from bytes the model embeds. A reference that cannot
// be read leaves its material with its factor alone and a warning naming it.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "renderer/scene/scene.h"

namespace caustica {

class TextureTable {
 public:
  // `model` is the model file: references are relative to its folder, and warnings name it.
  explicit TextureTable(const std::filesystem::path& model);

  // The texture of a file the model names, as an index into textures(), or kNoTexture (with a
  // warning) when it cannot be read. Windows separators in `reference` are read as '/', as the
  // exporters of OBJ and 3DS files write them.
  uint32_t from_file(absl::string_view reference, std::vector<std::string>& warnings);
  // The same, or why the file cannot be read (NOT_FOUND, or RESOURCE_EXHAUSTED over the size
  // limit), for references that must be read (a scene file's own maps).
  absl::StatusOr<uint32_t> read(absl::string_view reference);
  // A texture of bytes the model embeds, under `key` (one texture per key).
  uint32_t from_bytes(const std::string& key, std::string name, std::string bytes);

  std::vector<TextureImage> take() { return std::move(textures_); }

 private:
  std::filesystem::path folder_;
  std::string model_name_;
  std::vector<TextureImage> textures_;
  std::map<std::string, uint32_t> index_;  // by resolved path or embedding key
};

}  // namespace caustica
