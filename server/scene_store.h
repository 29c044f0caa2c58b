// Durable scenes under --data-dir (docs/server.md, "Durable scenes"). An uploaded scene's
// geometry is a content-addressed blob, blobs/<sha256>.scene, written to a temporary file,
// fsynced and renamed into place; an SQLite index in WAL mode (index.db) holds each scene's id,
// tenant, blob and its current lights, camera, settings and epochs. Every write is committed
// before the call that caused it is acknowledged, so a killed server restores exactly what clients
// were told. Uploads and deletes also reach the disk before that (synchronous=FULL); an update's
// commit is left to the operating system and synced by a background checkpoint within
// `update_sync_delay`, so that a light animation does not wait for the disk at every step. One
// server owns a directory at a time (an flock on its lock file).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "renderer/engine.h"
#include "renderer/scene/scene.h"

struct sqlite3;

namespace caustica::server {

// One index row: what restores a scene.
struct StoredScene {
  std::string id;
  std::string tenant;
  std::string name;
  std::string blob;  // the geometry's SHA-256, hex
  // The state that updates change; it overrides what the blob's header says.
  std::vector<Light> lights;
  std::vector<EmitterChange> emitters;  // every emissive material's emission; empty: the blob's
  EnvironmentChange environment;        // its intensity and rotation; unset: the blob's
  Camera camera;
  RenderSettings settings;
  std::vector<MeshChange> placements;  // the meshes UpdateGeometry moved, to redo after the load
  Epochs epochs;
  uint64_t upload_bytes = 0;
  double upload_ms = 0;
};

class SceneStore {
 public:
  // Creates the directory and index when missing, takes the lock, and removes temporary files a
  // killed server left behind and blobs no scene references.
  // Updates committed since the last sync reach the disk at most `update_sync_delay` later.
  static absl::StatusOr<std::unique_ptr<SceneStore>> open(
      const std::filesystem::path& dir,
      std::chrono::milliseconds update_sync_delay = std::chrono::seconds(1));
  ~SceneStore();
  SceneStore(const SceneStore&) = delete;
  SceneStore& operator=(const SceneStore&) = delete;

  const std::filesystem::path& dir() const { return dir_; }

  // Writes `scene`'s upload stream (header and chunks) as a blob and returns its digest. An
  // identical blob already stored is kept as it is.
  absl::StatusOr<std::string> write_blob(const Scene& scene, const std::string& name);
  // The scene a blob holds, its digest checked (DATA_LOSS when the file does not match it).
  absl::StatusOr<Scene> read_blob(const std::string& digest) const;
  // Removes the blob unless an index row references it (for an upload that failed after its
  // blob was written).
  void discard_blob(const std::string& digest);

  // Each commits before it returns; add and remove also sync the index to the disk.
  absl::Status add(const StoredScene& scene);
  // Stores `state`'s lights, emission, camera and settings, the meshes moved since upload
  // (Engine::placements) and `epochs` as scene `id`'s current state; it survives a killed server
  // at once, and a power loss once the next sync has run.
  absl::Status update(const std::string& id, const Scene& state,
                      const std::vector<MeshChange>& placements, const Epochs& epochs);
  // Removes the row, then its blob once no row references it. A missing id is not an error.
  absl::Status remove(const std::string& id);
  // Whether an update waits for the background sync.
  bool sync_pending() const;
  // Every stored scene in upload order.
  absl::StatusOr<std::vector<StoredScene>> list() const;

 private:
  SceneStore() = default;
  // Blobs in blobs/ that no row references are removed; so are leftovers in tmp/.
  void collect_garbage();
  // The background sync: a checkpoint, which syncs the write-ahead log first, once
  // `update_sync_delay_` after the first unsynced update, on a connection of its own and without
  // mutex_, so that updates go on while it waits for the disk.
  void sync_updates();
  bool blob_referenced(const std::string& digest) const;
  std::filesystem::path blob_path(const std::string& digest) const;

  std::filesystem::path dir_;
  int lock_fd_ = -1;
  sqlite3* db_ = nullptr;
  sqlite3* sync_db_ = nullptr;  // sync_updates' own connection
  mutable std::mutex mutex_;  // one connection, used by one call at a time
  std::chrono::milliseconds update_sync_delay_{0};
  // Guarded by mutex_: when the oldest update not yet on the disk committed, how many updates
  // have committed (so that the syncer knows which its checkpoint covered), and whether the store
  // is closing.
  std::optional<std::chrono::steady_clock::time_point> unsynced_since_;
  uint64_t updates_ = 0;
  bool closing_ = false;
  std::condition_variable sync_wake_;
  std::thread syncer_;
};

// A scene's stored state applied to the geometry of its blob.
Scene restored_scene(Scene geometry, const StoredScene& stored);

}  // namespace caustica::server
