// The resident scenes by id. An entry owns the scene's Engine and a snapshot of its SceneInfo
// that list/get/stats calls read without waiting for the device. The registry enforces
// --max-scenes, counting uploads still in progress, so a full server refuses an upload before the
// client has sent its mesh data.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"
#include "renderer/engine.h"

namespace caustica::server {

class SceneEntry {
 public:
  SceneEntry(std::string id, std::unique_ptr<Engine> engine, v1::SceneInfo info);

  const std::string& id() const { return id_; }

  // --- touched only under the device lease, which serialises every engine call ---
  // Null once the scene is deleted (calls still holding the entry then get NOT_FOUND).
  std::unique_ptr<Engine> engine;

  // --- the snapshot, any thread ---
  v1::SceneInfo info() const;
  // Refreshes the snapshot from the engine (under the device lease); `last_rebuild`, when given,
  // replaces SceneInfo.last_rebuild.
  void refresh(const v1::RebuildReport* last_rebuild = nullptr);

 private:
  const std::string id_;
  mutable std::mutex mutex_;  // guards info_
  v1::SceneInfo info_;
};

class SceneRegistry {
 public:
  explicit SceneRegistry(size_t max_scenes) : max_scenes_(max_scenes) {}

  // A place for one scene being uploaded; given back on destruction unless add() consumed it.
  class Slot {
   public:
    Slot() = default;
    Slot(Slot&& other) noexcept : registry_(std::exchange(other.registry_, nullptr)) {}
    Slot& operator=(Slot&&) = delete;
    ~Slot();

   private:
    friend class SceneRegistry;
    explicit Slot(SceneRegistry* registry) : registry_(registry) {}
    SceneRegistry* registry_ = nullptr;
  };

  // RESOURCE_EXHAUSTED when resident scenes and uploads in progress reach --max-scenes.
  absl::StatusOr<Slot> reserve();
  // A fresh id no resident scene uses: "s-" and 8 hex digits, random so that ids from an earlier
  // server run are unlikely to name a different scene now.
  std::string new_id();
  void add(Slot slot, std::shared_ptr<SceneEntry> entry);

  // INVALID_ARGUMENT for an empty id, NOT_FOUND for an unknown one; `field` names it.
  absl::StatusOr<std::shared_ptr<SceneEntry>> find(std::string_view id,
                                                   std::string_view field = "scene_id") const;
  // Removes the entry (later calls get NOT_FOUND) and returns it.
  absl::StatusOr<std::shared_ptr<SceneEntry>> remove(std::string_view id);
  // In upload order.
  std::vector<std::shared_ptr<SceneEntry>> list() const;

  size_t size() const;
  size_t max_scenes() const { return max_scenes_; }

 private:
  absl::Status check_known_locked(std::string_view id, std::string_view field) const;

  struct Resident {
    uint64_t sequence;
    std::shared_ptr<SceneEntry> entry;
  };
  const size_t max_scenes_;
  mutable std::mutex mutex_;
  std::map<std::string, Resident, std::less<>> scenes_;
  size_t uploads_in_progress_ = 0;
  uint64_t next_sequence_ = 0;
  std::mt19937_64 random_{std::random_device{}()};
};

}  // namespace caustica::server
