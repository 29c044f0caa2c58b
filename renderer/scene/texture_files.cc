#include "renderer/scene/texture_files.h"

#include <algorithm>
#include <memory>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "renderer/scene/file_io.h"
#include "renderer/scene/scene_limits.h"

namespace caustica {

TextureTable::TextureTable(const std::filesystem::path& model)
    : folder_(model.parent_path()), model_name_(model.filename().string()) {}

absl::StatusOr<uint32_t> TextureTable::read(absl::string_view reference) {
  std::string name(absl::StripAsciiWhitespace(reference));
  std::replace(name.begin(), name.end(), '\\', '/');
  const std::filesystem::path path = (folder_ / name).lexically_normal();
  const std::string key = path.string();
  if (const auto it = index_.find(key); it != index_.end()) return it->second;
  absl::StatusOr<std::string> bytes = read_file(path);
  if (!bytes.ok()) return bytes.status();
  if (bytes->size() > kMaxTextureFileBytes) {
    return absl::ResourceExhaustedError(
        absl::StrCat(path.string(), ": larger than ", kMaxTextureFileBytes >> 20, " MiB"));
  }
  return from_bytes(key, path.filename().string(), *std::move(bytes));
}

uint32_t TextureTable::from_file(absl::string_view reference, std::vector<std::string>& warnings) {
  absl::StatusOr<uint32_t> index = read(reference);
  if (index.ok()) return *index;
  warnings.push_back(absl::StrCat(model_name_, ": texture '", reference, "' cannot be read (",
                                  index.status().message(),
                                  "); its material keeps its colour alone"));
  return kNoTexture;
}

uint32_t TextureTable::from_bytes(const std::string& key, std::string name, std::string bytes) {
  if (const auto it = index_.find(key); it != index_.end()) return it->second;
  const auto index = static_cast<uint32_t>(textures_.size());
  TextureImage texture;
  texture.name = std::move(name);
  texture.encoded = std::make_shared<const std::string>(std::move(bytes));
  textures_.push_back(std::move(texture));
  index_.emplace(key, index);
  return index;
}

}  // namespace caustica
