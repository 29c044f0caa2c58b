#include "server/scene_registry.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "server/engine_wire.h"

namespace caustica::server {

SceneEntry::SceneEntry(std::string id, std::string tenant, std::vector<uint32_t> devices,
                       std::unique_ptr<Engine> engine_in, v1::SceneInfo info)
    : engine(std::move(engine_in)),
      id_(std::move(id)),
      tenant_(std::move(tenant)),
      devices_(std::move(devices)),
      info_(std::move(info)) {
  info_.set_scene_id(id_);
  info_.mutable_devices()->Assign(devices_.begin(), devices_.end());
}

v1::SceneInfo SceneEntry::info() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return info_;
}

void SceneEntry::refresh(const v1::RebuildReport* last_rebuild) {
  if (!engine) return;
  v1::SceneInfo info = this->info();
  describe_state(*engine, &info);
  // Lights change only with an update (which reports a rebuild), not with every pass.
  if (last_rebuild != nullptr) {
    describe_lights(engine->scene(), &info);
    *info.mutable_last_rebuild() = *last_rebuild;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  info_ = std::move(info);
}

SceneRegistry::Slot::~Slot() {
  if (registry_ == nullptr) return;
  std::lock_guard<std::mutex> lock(registry_->mutex_);
  --registry_->uploads_in_progress_;
  --registry_->tenant_uploads_[tenant_];
}

size_t SceneRegistry::resident_count_locked(std::string_view tenant) const {
  size_t count = 0;
  for (const auto& [id, resident] : scenes_) count += resident.entry->tenant() == tenant;
  return count;
}

void SceneRegistry::insert_locked(std::shared_ptr<SceneEntry> entry) {
  entry->touch();
  const std::string id = entry->id();
  scenes_.emplace(id, Resident{next_sequence_++, std::move(entry)});
}

absl::StatusOr<SceneRegistry::Slot> SceneRegistry::reserve(const std::string& tenant) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (scenes_.size() + uploads_in_progress_ >= max_scenes_) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "the server holds its maximum of %d scenes (%d resident, %d uploading; --max-scenes); "
        "delete one first",
        max_scenes_, scenes_.size(), uploads_in_progress_));
  }
  auto uploading = tenant_uploads_.find(tenant);
  const size_t held =
      resident_count_locked(tenant) + (uploading == tenant_uploads_.end() ? 0 : uploading->second);
  if (max_tenant_scenes_ > 0 && held >= max_tenant_scenes_) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "tenant '%s' holds its maximum of %d scenes, uploads included (--tenant-max-scenes); "
        "delete one first",
        tenant, max_tenant_scenes_));
  }
  ++uploads_in_progress_;
  ++tenant_uploads_[tenant];
  return Slot(this, tenant);
}

std::string SceneRegistry::new_id() {
  std::lock_guard<std::mutex> lock(mutex_);
  while (true) {
    std::string id = absl::StrFormat("s-%08x", static_cast<uint32_t>(random_()));
    if (!scenes_.contains(id) && !kept_ids_.contains(id)) return id;
  }
}

void SceneRegistry::add(Slot slot, std::shared_ptr<SceneEntry> entry) {
  std::lock_guard<std::mutex> lock(mutex_);
  // The slot's count moves into scenes_.
  slot.registry_ = nullptr;
  --uploads_in_progress_;
  --tenant_uploads_[slot.tenant_];
  insert_locked(std::move(entry));
}

void SceneRegistry::add_restored(std::shared_ptr<SceneEntry> entry) {
  std::lock_guard<std::mutex> lock(mutex_);
  insert_locked(std::move(entry));
}

void SceneRegistry::keep_id(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  kept_ids_.insert(id);
}

absl::StatusOr<std::shared_ptr<SceneEntry>> SceneRegistry::find(std::string_view id,
                                                                std::string_view tenant,
                                                                std::string_view field) const {
  if (id.empty()) return absl::InvalidArgumentError(absl::StrCat(std::string(field), ": is empty"));
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = scenes_.find(id);
  // Another tenant's scene gets the same answer as an unknown id: its existence is not revealed.
  if (it == scenes_.end() || it->second.entry->tenant() != tenant) {
    return absl::NotFoundError(
        absl::StrCat(std::string(field), ": no scene '", std::string(id), "' on this server"));
  }
  it->second.entry->touch();
  return it->second.entry;
}

bool SceneRegistry::remove(const SceneEntry& entry) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = scenes_.find(entry.id());
  if (it == scenes_.end() || it->second.entry.get() != &entry) return false;
  scenes_.erase(it);
  return true;
}

std::vector<std::shared_ptr<SceneEntry>> SceneRegistry::list_all() const {
  std::vector<const Resident*> ordered;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [id, resident] : scenes_) ordered.push_back(&resident);
  std::sort(ordered.begin(), ordered.end(),
            [](const Resident* a, const Resident* b) { return a->sequence < b->sequence; });
  std::vector<std::shared_ptr<SceneEntry>> out;
  for (const Resident* r : ordered) out.push_back(r->entry);
  return out;
}

std::vector<std::shared_ptr<SceneEntry>> SceneRegistry::list(std::string_view tenant) const {
  std::vector<std::shared_ptr<SceneEntry>> out = list_all();
  std::erase_if(out, [&](const auto& entry) { return entry->tenant() != tenant; });
  return out;
}

size_t SceneRegistry::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return scenes_.size();
}

size_t SceneRegistry::size(std::string_view tenant) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return resident_count_locked(tenant);
}

}  // namespace caustica::server
