// SceneStore on its own: blobs round-trip and are content-addressed, damage is DATA_LOSS, the
// index keeps each scene's state, updates reach the disk within their delay, and what a killed
// server leaves half-written is collected.
#include "server/scene_store.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <thread>

#include "tests/server/server_harness.h"

namespace caustica::server {
namespace {

namespace fs = std::filesystem;
using caustica::testing::cornell_box;
using caustica::testing::make_temp_dir;

size_t files_in(const fs::path& dir) {
  size_t count = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++count;
  return count;
}

StoredScene row(const std::string& id, const std::string& blob, const Scene& scene) {
  return {.id = id,
          .tenant = "studio",
          .name = "box",
          .blob = blob,
          .lights = scene.lights,
          .camera = scene.camera,
          .settings = scene.settings,
          .epochs = {1, 2, 3, 4},
          .upload_bytes = 1234,
          .upload_ms = 5.5};
}

TEST(SceneStore, BlobsRoundTripAndAreContentAddressed) {
  const fs::path dir = make_temp_dir("scene-store");
  auto store = SceneStore::open(dir);
  ASSERT_TRUE(store.ok()) << store.status();
  const Scene scene = cornell_box(24, 16, 1000, 8, 3);
  absl::StatusOr<std::string> digest = (*store)->write_blob(scene, "box");
  ASSERT_TRUE(digest.ok()) << digest.status();
  EXPECT_EQ(digest->size(), 64u);
  absl::StatusOr<std::string> again = (*store)->write_blob(scene, "box");
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, *digest);
  EXPECT_EQ(files_in(dir / "blobs"), 1u);
  EXPECT_EQ(files_in(dir / "tmp"), 0u);

  absl::StatusOr<Scene> read = (*store)->read_blob(*digest);
  ASSERT_TRUE(read.ok()) << read.status();
  ASSERT_EQ(read->meshes.size(), scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    EXPECT_EQ(read->meshes[m].positions, scene.meshes[m].positions);
    EXPECT_EQ(read->meshes[m].indices, scene.meshes[m].indices);
  }
  EXPECT_EQ(read->camera.width, 24);
  EXPECT_EQ(read->settings.photons_per_pass, 1000u);

  // Another name is another header, hence another blob.
  absl::StatusOr<std::string> other = (*store)->write_blob(scene, "box 2");
  ASSERT_TRUE(other.ok());
  EXPECT_NE(*other, *digest);
}

TEST(SceneStore, DamagedOrMissingBlobsAreDataLoss) {
  const fs::path dir = make_temp_dir("scene-store");
  auto store = SceneStore::open(dir);
  ASSERT_TRUE(store.ok());
  absl::StatusOr<std::string> digest = (*store)->write_blob(cornell_box(8, 8, 100, 4, 1), "box");
  ASSERT_TRUE(digest.ok());
  const fs::path path = dir / "blobs" / (*digest + ".scene");
  {
    // One flipped byte deep in the mesh data parses fine; only the digest catches it.
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(static_cast<std::streamoff>(fs::file_size(path) - 5));
    file.put('\x5a');
  }
  absl::StatusOr<Scene> damaged = (*store)->read_blob(*digest);
  EXPECT_EQ(damaged.status().code(), absl::StatusCode::kDataLoss) << damaged.status();
  fs::resize_file(path, 100);
  EXPECT_EQ((*store)->read_blob(*digest).status().code(), absl::StatusCode::kDataLoss);
  fs::remove(path);
  absl::StatusOr<Scene> missing = (*store)->read_blob(*digest);
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(missing.status().message().find("missing"), std::string::npos);
}

TEST(SceneStore, IndexKeepsStateAcrossReopen) {
  const fs::path dir = make_temp_dir("scene-store");
  Scene scene = cornell_box(16, 16, 500, 8, 2);
  std::string digest;
  {
    auto store = SceneStore::open(dir);
    ASSERT_TRUE(store.ok());
    digest = *(*store)->write_blob(scene, "box");
    ASSERT_TRUE((*store)->add(row("s-1", digest, scene)).ok());
    ASSERT_TRUE((*store)->add(row("s-2", digest, scene)).ok());
    // Ids are unique.
    EXPECT_FALSE((*store)->add(row("s-1", digest, scene)).ok());
    Light light;
    light.intensity = {7, 8, 9};
    scene.lights = {light};
    scene.camera.width = 40;
    scene.settings.k_nearest = 33;
    ASSERT_TRUE((*store)->update("s-2", scene, {}, {5, 6, 7, 8}).ok());
  }
  auto store = SceneStore::open(dir);
  ASSERT_TRUE(store.ok());
  absl::StatusOr<std::vector<StoredScene>> rows = (*store)->list();
  ASSERT_TRUE(rows.ok()) << rows.status();
  ASSERT_EQ(rows->size(), 2u);
  EXPECT_EQ((*rows)[0].id, "s-1");
  EXPECT_EQ((*rows)[0].epochs.settings, 4u);
  const StoredScene& updated = (*rows)[1];
  EXPECT_EQ(updated.id, "s-2");
  EXPECT_EQ(updated.tenant, "studio");
  EXPECT_EQ(updated.upload_bytes, 1234u);
  EXPECT_EQ(updated.epochs.geometry, 5u);
  EXPECT_EQ(updated.epochs.settings, 8u);
  ASSERT_EQ(updated.lights.size(), 1u);
  EXPECT_EQ(updated.lights[0].intensity.x, 7);
  EXPECT_EQ(updated.camera.width, 40);
  EXPECT_EQ(updated.settings.k_nearest, 33u);
  EXPECT_EQ(updated.settings.photons_per_pass, 500u);

  // The shared blob stays until its last row goes.
  ASSERT_TRUE((*store)->remove("s-1").ok());
  EXPECT_TRUE(fs::exists(dir / "blobs" / (digest + ".scene")));
  ASSERT_TRUE((*store)->remove("s-2").ok());
  EXPECT_FALSE(fs::exists(dir / "blobs" / (digest + ".scene")));
  EXPECT_TRUE((*store)->remove("s-2").ok());  // already gone: nothing to do
  EXPECT_TRUE((*store)->list()->empty());
}

// Scene `id`'s lights epoch as the index's database file holds it, without its write-ahead log
// (an immutable reader ignores the log): what a power loss would leave. Nothing when the row is
// only in the log.
std::optional<int64_t> lights_epoch_on_disk(const fs::path& dir, const std::string& id) {
  const std::string uri = "file:" + (dir / "index.db").string() + "?immutable=1";
  sqlite3* db = nullptr;
  std::optional<int64_t> epoch;
  if (sqlite3_open_v2(uri.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr) ==
      SQLITE_OK) {
    sqlite3_stmt* query = nullptr;
    if (sqlite3_prepare_v2(db, "SELECT epoch_lights FROM scenes WHERE id = ?", -1, &query,
                           nullptr) == SQLITE_OK) {
      sqlite3_bind_text(query, 1, id.c_str(), -1, SQLITE_TRANSIENT);
      if (sqlite3_step(query) == SQLITE_ROW) epoch = sqlite3_column_int64(query, 0);
    }
    sqlite3_finalize(query);
  }
  sqlite3_close(db);
  return epoch;
}

// Whether the store's background sync has caught up within `limit`.
bool synced_within(const SceneStore& store, std::chrono::seconds limit) {
  const auto give_up = std::chrono::steady_clock::now() + limit;
  while (store.sync_pending() && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return !store.sync_pending();
}

// A store in a new directory syncing updates `delay` after the first, holding one scene, s-1.
std::unique_ptr<SceneStore> store_with_one_scene(const fs::path& dir,
                                                 std::chrono::milliseconds delay) {
  auto store = SceneStore::open(dir, delay);
  EXPECT_TRUE(store.ok()) << store.status();
  if (!store.ok()) return nullptr;
  const Scene scene = cornell_box(8, 8, 100, 4, 1);
  absl::StatusOr<std::string> digest = (*store)->write_blob(scene, "box");
  EXPECT_TRUE(digest.ok() && (*store)->add(row("s-1", *digest, scene)).ok());
  return *std::move(store);
}

TEST(SceneStore, AnUpdateReachesTheDiskWithinItsSyncDelay) {
  const fs::path dir = make_temp_dir("scene-store");
  const Scene scene = cornell_box(8, 8, 100, 4, 1);
  const std::unique_ptr<SceneStore> store = store_with_one_scene(dir, std::chrono::milliseconds(20));
  ASSERT_NE(store, nullptr);
  EXPECT_FALSE(store->sync_pending());  // an upload is synced before it returns
  ASSERT_TRUE(store->update("s-1", scene, {}, {1, 9, 3, 4}).ok());
  EXPECT_TRUE(synced_within(*store, std::chrono::seconds(20)));
  // The checkpoint that synced the log also moved the update into the database file.
  EXPECT_EQ(lights_epoch_on_disk(dir, "s-1"), 9);
}

TEST(SceneStore, UpdatesGoOnWhileTheSyncerCheckpoints) {
  // A sync every millisecond or so, each on the syncer's own connection while updates commit on
  // the store's: none fails, and the last one is what the disk holds once the syncer has run.
  const fs::path dir = make_temp_dir("scene-store");
  const Scene scene = cornell_box(8, 8, 100, 4, 1);
  const std::unique_ptr<SceneStore> store = store_with_one_scene(dir, std::chrono::milliseconds(1));
  ASSERT_NE(store, nullptr);
  for (uint32_t epoch = 10; epoch < 400; ++epoch) {
    ASSERT_TRUE(store->update("s-1", scene, {}, {1, epoch, 3, 4}).ok()) << epoch;
  }
  EXPECT_TRUE(synced_within(*store, std::chrono::seconds(20)));
  EXPECT_EQ(lights_epoch_on_disk(dir, "s-1"), 399);
}

TEST(SceneStore, AnUnsyncedUpdateIsReadBackAndSyncedOnClose) {
  const fs::path dir = make_temp_dir("scene-store");
  const Scene scene = cornell_box(8, 8, 100, 4, 1);
  {
    const std::unique_ptr<SceneStore> store = store_with_one_scene(dir, std::chrono::hours(1));
    ASSERT_NE(store, nullptr);
    ASSERT_TRUE(store->update("s-1", scene, {}, {1, 9, 3, 4}).ok());
    EXPECT_TRUE(store->sync_pending());
    EXPECT_NE(lights_epoch_on_disk(dir, "s-1"), 9);  // in the log only
    // The store's own reader sees the log.
    EXPECT_EQ(store->list()->at(0).epochs.lights, 9u);
  }  // closing does not wait an hour
  EXPECT_EQ(lights_epoch_on_disk(dir, "s-1"), 9);
}

// The meshes UpdateGeometry moved are part of the state: transforms, and vertices where they were
// replaced, read back as they were stored.
TEST(SceneStore, MovedMeshesAreReadBack) {
  const fs::path dir = make_temp_dir("scene-store");
  const Scene scene = cornell_box(8, 8, 100, 4, 1);
  const std::unique_ptr<SceneStore> store = store_with_one_scene(dir, std::chrono::hours(1));
  ASSERT_NE(store, nullptr);
  Affine turned = rotation_y_deg(30);
  turned.m[0][3] = 12.5;
  const std::vector<MeshChange> placements = {
      {"shapes[0] 'floor'", turned, std::nullopt, std::nullopt},
      {"shapes[1]", Affine(), std::vector<Vec3f>{{1, 2, 3}, {4, 5, 6}},
       std::vector<Vec3f>{{0, 1, 0}, {0, 0, 1}}}};
  ASSERT_TRUE(store->update("s-1", scene, placements, {2, 2, 1, 1}).ok());
  const absl::StatusOr<std::vector<StoredScene>> listed = store->list();
  ASSERT_TRUE(listed.ok()) << listed.status();
  const std::vector<MeshChange>& back = listed->at(0).placements;
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].mesh, "shapes[0] 'floor'");
  ASSERT_TRUE(back[0].transform.has_value());
  EXPECT_EQ(back[0].transform->m, turned.m);
  EXPECT_FALSE(back[0].positions || back[0].normals);
  EXPECT_EQ(back[1].mesh, "shapes[1]");
  ASSERT_TRUE(back[1].positions && back[1].normals);
  EXPECT_EQ(back[1].positions->size(), 2u);
  EXPECT_EQ(back[1].positions->at(1).z, 6.0f);
  EXPECT_EQ(back[1].normals->at(1).z, 1.0f);
}

TEST(SceneStore, LeftoversOfAKilledServerAreCollected) {
  const fs::path dir = make_temp_dir("scene-store");
  std::string kept, orphan;
  {
    auto store = SceneStore::open(dir);
    ASSERT_TRUE(store.ok());
    const Scene scene = cornell_box(8, 8, 100, 4, 1);
    kept = *(*store)->write_blob(scene, "kept");
    ASSERT_TRUE((*store)->add(row("s-kept", kept, scene)).ok());
    // Written but never indexed: the upload died before it was acknowledged.
    orphan = *(*store)->write_blob(scene, "orphan");
    std::ofstream(dir / "tmp" / "blob-half") << "half a blob";
  }
  auto store = SceneStore::open(dir);
  ASSERT_TRUE(store.ok());
  EXPECT_TRUE(fs::exists(dir / "blobs" / (kept + ".scene")));
  EXPECT_FALSE(fs::exists(dir / "blobs" / (orphan + ".scene")));
  EXPECT_EQ(files_in(dir / "tmp"), 0u);
  EXPECT_EQ((*store)->list()->size(), 1u);
}

TEST(SceneStore, OneServerPerDirectory) {
  const fs::path dir = make_temp_dir("scene-store");
  auto first = SceneStore::open(dir);
  ASSERT_TRUE(first.ok());
  auto second = SceneStore::open(dir);
  EXPECT_EQ(second.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(second.status().message().find("in use"), std::string::npos) << second.status();
  first->reset();
  EXPECT_TRUE(SceneStore::open(dir).ok());
}

TEST(SceneStore, AFileInTheWayIsNamed) {
  const fs::path dir = make_temp_dir("scene-store");
  std::ofstream(dir / "file") << "x";
  auto store = SceneStore::open(dir / "file");
  EXPECT_FALSE(store.ok());
  EXPECT_NE(store.status().message().find("--data-dir"), std::string::npos) << store.status();
  std::ofstream(dir / "index.db")
      << "this is not a database, only text long enough to look like one";
  auto bad_index = SceneStore::open(dir);
  EXPECT_FALSE(bad_index.ok());
  EXPECT_NE(bad_index.status().message().find("index.db"), std::string::npos) << bad_index.status();
}

}  // namespace
}  // namespace caustica::server
