// The resident scenes by id. An entry owns the scene's Engine and a snapshot of its SceneInfo
// that list/get/stats calls read without waiting for the device. Every scene belongs to the
// tenant that uploaded it, and another tenant's scene is NOT_FOUND as if it did not exist. The
// registry enforces --max-scenes and --tenant-max-scenes, counting uploads still in progress, so
// a full server refuses an upload before the client has sent its mesh data.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"
#include "renderer/engine.h"

namespace caustica::server {

class SceneEntry {
 public:
  // `devices`: the server's devices the engine works on, ascending; also SceneInfo.devices.
  SceneEntry(std::string id, std::string tenant, std::vector<uint32_t> devices,
             std::unique_ptr<Engine> engine, v1::SceneInfo info);

  const std::string& id() const { return id_; }
  // Who uploaded it; only calls of the same tenant see it.
  const std::string& tenant() const { return tenant_; }
  // Where the scene lives; engine calls hold the leases of all of these devices.
  const std::vector<uint32_t>& devices() const { return devices_; }

  // --- touched only under the leases of its devices, which serialise every engine call ---
  // Null once the scene is deleted (calls still holding the entry then get NOT_FOUND).
  std::unique_ptr<Engine> engine;

  // --- the snapshot, any thread ---
  v1::SceneInfo info() const;
  // Refreshes the snapshot from the engine (under the device lease); `last_rebuild`, when given,
  // replaces SceneInfo.last_rebuild.
  void refresh(const v1::RebuildReport* last_rebuild = nullptr);

  // When a call last found the scene or rendered it, for --scene-idle-ttl.
  void touch() const { last_used_ = std::chrono::steady_clock::now().time_since_epoch().count(); }
  std::chrono::steady_clock::time_point last_used() const {
    return std::chrono::steady_clock::time_point(std::chrono::steady_clock::duration(last_used_));
  }

 private:
  mutable std::atomic<std::chrono::steady_clock::rep> last_used_;
  const std::string id_;
  const std::string tenant_;
  const std::vector<uint32_t> devices_;
  mutable std::mutex mutex_;  // guards info_
  v1::SceneInfo info_;
};

class SceneRegistry {
 public:
  // `max_tenant_scenes` 0: a tenant may hold all of `max_scenes`.
  SceneRegistry(size_t max_scenes, size_t max_tenant_scenes)
      : max_scenes_(max_scenes), max_tenant_scenes_(max_tenant_scenes) {}

  // A place for one scene being uploaded; given back on destruction unless add() consumed it.
  class Slot {
   public:
    Slot() = default;
    Slot(Slot&& other) noexcept
        : registry_(std::exchange(other.registry_, nullptr)), tenant_(std::move(other.tenant_)) {}
    Slot& operator=(Slot&&) = delete;
    ~Slot();

   private:
    friend class SceneRegistry;
    Slot(SceneRegistry* registry, std::string tenant)
        : registry_(registry), tenant_(std::move(tenant)) {}
    SceneRegistry* registry_ = nullptr;
    std::string tenant_;
  };

  // RESOURCE_EXHAUSTED when resident scenes and uploads in progress reach --max-scenes, or the
  // tenant's reach --tenant-max-scenes.
  absl::StatusOr<Slot> reserve(const std::string& tenant);
  // A fresh id no resident scene uses: "s-" and 8 hex digits, random so that ids from an earlier
  // server run are unlikely to name a different scene now.
  std::string new_id();
  void add(Slot slot, std::shared_ptr<SceneEntry> entry);
  // A scene restored from --data-dir: it was acknowledged before, so --max-scenes does not
  // refuse it.
  void add_restored(std::shared_ptr<SceneEntry> entry);
  // Keeps new_id() from handing out the id of a stored scene that could not be restored.
  void keep_id(const std::string& id);

  // INVALID_ARGUMENT for an empty id, NOT_FOUND for an unknown one or another tenant's; `field`
  // names it. Marks the scene used.
  absl::StatusOr<std::shared_ptr<SceneEntry>> find(std::string_view id, std::string_view tenant,
                                                   std::string_view field = "scene_id") const;
  // Removes `entry` (later calls get NOT_FOUND); false when it was removed already.
  bool remove(const SceneEntry& entry);
  // The tenant's scenes in upload order.
  std::vector<std::shared_ptr<SceneEntry>> list(std::string_view tenant) const;
  // Every tenant's, for the idle reaper and the server-wide figures.
  std::vector<std::shared_ptr<SceneEntry>> list_all() const;

  size_t size() const;
  size_t size(std::string_view tenant) const;
  size_t max_scenes() const { return max_scenes_; }

 private:
  size_t resident_count_locked(std::string_view tenant) const;
  // Adds a scene, marked used, after every scene already in.
  void insert_locked(std::shared_ptr<SceneEntry> entry);

  struct Resident {
    uint64_t sequence;
    std::shared_ptr<SceneEntry> entry;
  };
  const size_t max_scenes_;
  const size_t max_tenant_scenes_;
  mutable std::mutex mutex_;
  std::map<std::string, Resident, std::less<>> scenes_;
  std::set<std::string, std::less<>> kept_ids_;
  size_t uploads_in_progress_ = 0;
  std::map<std::string, size_t, std::less<>> tenant_uploads_;
  uint64_t next_sequence_ = 0;
  std::mt19937_64 random_{std::random_device{}()};
};

}  // namespace caustica::server
