#include "server/scene_registry.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "server/engine_wire.h"

namespace caustica::server {

SceneEntry::SceneEntry(std::string id, std::unique_ptr<Engine> engine_in, v1::SceneInfo info)
    : engine(std::move(engine_in)), id_(std::move(id)), info_(std::move(info)) {
  info_.set_scene_id(id_);
}

v1::SceneInfo SceneEntry::info() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return info_;
}

void SceneEntry::refresh(const v1::RebuildReport* last_rebuild) {
  if (!engine) return;
  v1::SceneInfo info = this->info();
  describe_state(*engine, &info);
  if (last_rebuild != nullptr) *info.mutable_last_rebuild() = *last_rebuild;
  std::lock_guard<std::mutex> lock(mutex_);
  info_ = std::move(info);
}

SceneRegistry::Slot::~Slot() {
  if (registry_ == nullptr) return;
  std::lock_guard<std::mutex> lock(registry_->mutex_);
  --registry_->uploads_in_progress_;
}

absl::StatusOr<SceneRegistry::Slot> SceneRegistry::reserve() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (scenes_.size() + uploads_in_progress_ >= max_scenes_) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "the server holds its maximum of %d scenes (%d resident, %d uploading; --max-scenes); "
        "delete one first",
        max_scenes_, scenes_.size(), uploads_in_progress_));
  }
  ++uploads_in_progress_;
  return Slot(this);
}

std::string SceneRegistry::new_id() {
  std::lock_guard<std::mutex> lock(mutex_);
  while (true) {
    std::string id = absl::StrFormat("s-%08x", static_cast<uint32_t>(random_()));
    if (!scenes_.contains(id)) return id;
  }
}

void SceneRegistry::add(Slot slot, std::shared_ptr<SceneEntry> entry) {
  std::lock_guard<std::mutex> lock(mutex_);
  // The slot's count moves into scenes_.
  slot.registry_ = nullptr;
  --uploads_in_progress_;
  const std::string id = entry->id();
  scenes_.emplace(id, Resident{next_sequence_++, std::move(entry)});
}

absl::Status SceneRegistry::check_known_locked(std::string_view id, std::string_view field) const {
  if (id.empty()) return absl::InvalidArgumentError(absl::StrCat(std::string(field), ": is empty"));
  if (!scenes_.contains(id)) {
    return absl::NotFoundError(
        absl::StrCat(std::string(field), ": no scene '", std::string(id), "' on this server"));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<SceneEntry>> SceneRegistry::find(std::string_view id,
                                                                std::string_view field) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (absl::Status known = check_known_locked(id, field); !known.ok()) return known;
  return scenes_.find(id)->second.entry;
}

absl::StatusOr<std::shared_ptr<SceneEntry>> SceneRegistry::remove(std::string_view id) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (absl::Status known = check_known_locked(id, "scene_id"); !known.ok()) return known;
  auto it = scenes_.find(id);
  std::shared_ptr<SceneEntry> removed = std::move(it->second.entry);
  scenes_.erase(it);
  return removed;
}

std::vector<std::shared_ptr<SceneEntry>> SceneRegistry::list() const {
  std::vector<const Resident*> ordered;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [id, resident] : scenes_) ordered.push_back(&resident);
  std::sort(ordered.begin(), ordered.end(),
            [](const Resident* a, const Resident* b) { return a->sequence < b->sequence; });
  std::vector<std::shared_ptr<SceneEntry>> out;
  for (const Resident* r : ordered) out.push_back(r->entry);
  return out;
}

size_t SceneRegistry::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return scenes_.size();
}

}  // namespace caustica::server
