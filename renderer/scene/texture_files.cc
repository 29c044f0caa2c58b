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

uint32_t TextureTable::from_file(absl::string_view reference, std::vector<std::string>& warnings) {
  std::string name(absl::StripAsciiWhitespace(reference));
  std::replace(name.begin(), name.end(), '\\', '/');
  const std::filesystem::path path = (folder_ / name).lexically_normal();
  const std::string key = path.string();
  if (const auto it = index_.find(key); it != index_.end()) return it->second;
  absl::StatusOr<std::string> bytes = read_file(path);
  if (bytes.ok() && bytes->size() > kMaxTextureFileBytes) {
    bytes = absl::ResourceExhaustedError(
        absl::StrCat("larger than ", kMaxTextureFileBytes >> 20, " MiB"));
  }
  if (!bytes.ok()) {
    warnings.push_back(absl::StrCat(model_name_, ": texture '", reference, "' cannot be read (",
                                    bytes.status().message(),
                                    "); its material keeps its colour alone"));
    index_.emplace(key, kNoTexture);
    return kNoTexture;
  }
  return from_bytes(key, path.filename().string(), *std::move(bytes));
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
