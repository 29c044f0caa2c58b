#include "server/scene_store.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <initializer_list>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "caustica/v1/scene.pb.h"
#include "proto/wire/scene_wire.h"
#include "server/log.h"

namespace caustica::server {
namespace {

namespace fs = std::filesystem;

// Leads every blob; the digest covers it, so a blob of another format never matches a digest.
constexpr char kBlobMagic[8] = {'C', 'A', 'U', 'S', 'S', 'C', 'N', '1'};
// No chunk the wire allows comes near this; a larger record length means a damaged file.
constexpr uint64_t kMaxRecordBytes = uint64_t{64} << 20;

std::string errno_text() { return std::strerror(errno); }

absl::Status exec_sql(sqlite3* db, const char* sql) {
  char* message = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    absl::Status status = absl::InternalError(message != nullptr ? message : "sqlite error");
    sqlite3_free(message);
    return status;
  }
  return absl::OkStatus();
}

// Opens `index` with `flags` on `*db` and runs `setup` on it, each failure named for --data-dir.
absl::Status open_index(const fs::path& index, int flags,
                        std::initializer_list<const char*> setup, sqlite3** db) {
  if (sqlite3_open_v2(index.c_str(), db, flags | SQLITE_OPEN_FULLMUTEX, nullptr) != SQLITE_OK) {
    return absl::InvalidArgumentError(
        absl::StrCat("--data-dir: cannot open ", index.string(), ": ", sqlite3_errmsg(*db)));
  }
  sqlite3_busy_timeout(*db, 5000);
  for (const char* sql : setup) {
    if (absl::Status s = exec_sql(*db, sql); !s.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--data-dir: ", index.string(), " is not a usable scene index: ", s.message()));
    }
  }
  return absl::OkStatus();
}

// Commits in its scope sync the log to the disk (synchronous=FULL) on the store's connection,
// whose commits otherwise leave that to the syncer (NORMAL).
class FullSync {
 public:
  explicit FullSync(sqlite3* db) : db_(db), status_(exec_sql(db, "PRAGMA synchronous=FULL;")) {}
  ~FullSync() { exec_sql(db_, "PRAGMA synchronous=NORMAL;").IgnoreError(); }
  FullSync(const FullSync&) = delete;
  FullSync& operator=(const FullSync&) = delete;
  const absl::Status& status() const { return status_; }

 private:
  sqlite3* db_;
  absl::Status status_;
};

absl::Status fsync_path(const fs::path& path, int flags) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC);
  if (fd < 0)
    return absl::InternalError(absl::StrCat("cannot open ", path.string(), ": ", errno_text()));
  const int synced = ::fsync(fd);
  ::close(fd);
  if (synced != 0)
    return absl::InternalError(absl::StrCat("cannot sync ", path.string(), ": ", errno_text()));
  return absl::OkStatus();
}

class Sha256 {
 public:
  Sha256() : context_(EVP_MD_CTX_new()) { EVP_DigestInit_ex(context_, EVP_sha256(), nullptr); }
  ~Sha256() { EVP_MD_CTX_free(context_); }
  void update(std::string_view bytes) { EVP_DigestUpdate(context_, bytes.data(), bytes.size()); }
  std::string hex() {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int size = 0;
    EVP_DigestFinal_ex(context_, digest, &size);
    static constexpr char kHex[] = "0123456789abcdef";
    std::string out;
    for (unsigned int i = 0; i < size; ++i) {
      out += kHex[digest[i] >> 4];
      out += kHex[digest[i] & 15];
    }
    return out;
  }

 private:
  EVP_MD_CTX* context_;
};

// Writes everything or says why not.
absl::Status write_all(int fd, std::string_view bytes, const fs::path& path) {
  while (!bytes.empty()) {
    const ssize_t written = ::write(fd, bytes.data(), bytes.size());
    if (written < 0) {
      if (errno == EINTR) continue;
      return absl::InternalError(absl::StrCat("cannot write ", path.string(), ": ", errno_text()));
    }
    bytes.remove_prefix(static_cast<size_t>(written));
  }
  return absl::OkStatus();
}

void append_record(std::string& buffer, const v1::SceneChunk& chunk) {
  const std::string bytes = chunk.SerializeAsString();
  uint64_t length = bytes.size();
  char prefix[8];
  for (int i = 0; i < 8; ++i) prefix[i] = static_cast<char>((length >> (8 * i)) & 0xff);
  buffer.append(prefix, 8);
  buffer += bytes;
}

// A prepared statement, finalized when it goes out of scope.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &statement_, nullptr) != SQLITE_OK) statement_ = nullptr;
  }
  ~Statement() { sqlite3_finalize(statement_); }
  bool ok() const { return statement_ != nullptr; }
  void bind(int index, const std::string& text) {
    sqlite3_bind_blob(statement_, index, text.data(), static_cast<int>(text.size()),
                      SQLITE_TRANSIENT);
  }
  void bind_text(int index, const std::string& text) {
    sqlite3_bind_text(statement_, index, text.data(), static_cast<int>(text.size()),
                      SQLITE_TRANSIENT);
  }
  void bind(int index, int64_t value) { sqlite3_bind_int64(statement_, index, value); }
  void bind(int index, double value) { sqlite3_bind_double(statement_, index, value); }
  // SQLITE_ROW, SQLITE_DONE or an error code.
  int step() { return sqlite3_step(statement_); }
  std::string text(int column) const {
    const void* data = sqlite3_column_blob(statement_, column);
    const int size = sqlite3_column_bytes(statement_, column);
    return data == nullptr ? std::string() : std::string(static_cast<const char*>(data), size);
  }
  int64_t integer(int column) const { return sqlite3_column_int64(statement_, column); }
  double real(int column) const { return sqlite3_column_double(statement_, column); }
  absl::Status error(absl::string_view what) const {
    return absl::InternalError(absl::StrCat("scene index: ", what, ": ", sqlite3_errmsg(db_)));
  }

 private:
  sqlite3* db_;
  sqlite3_stmt* statement_ = nullptr;
};

// Each emissive material's emission, as the state keeps it.
std::vector<EmitterChange> emission_of(const std::vector<Material>& materials) {
  std::vector<EmitterChange> out;
  for (const Material& m : materials) {
    if (is_emitter(m)) out.push_back({m.name, m.radiance, m.off});
  }
  return out;
}

// The environment's intensity and rotation, as the state keeps them.
EnvironmentChange environment_of(const Environment& environment) {
  if (!environment.present) return {};
  return {environment.intensity, environment.rotation_deg};
}

// Lights, emission, the environment's intensity and rotation, camera and settings as a
// SceneHeader holding only those fields (emission as EMISSIVE materials with their name, radiance
// and off).
std::string encode_state(const std::vector<Light>& lights,
                         const std::vector<EmitterChange>& emitters,
                         const EnvironmentChange& environment, const Camera& camera,
                         const RenderSettings& settings,
                         const std::vector<MeshChange>& placements) {
  v1::SceneHeader header;
  for (const MeshChange& placed : placements)
    *header.add_placements() = wire::encode_mesh_change(placed);
  for (const Light& light : lights) *header.add_lights() = wire::encode_light(light);
  if (environment.intensity || environment.rotation_deg) {
    v1::Environment& e = *header.mutable_environment();
    if (environment.intensity) e.set_intensity(*environment.intensity);
    e.set_rotation_deg(environment.rotation_deg.value_or(0.0f));
  }
  for (const EmitterChange& emitter : emitters) {
    v1::Material& material = *header.add_materials();
    material.set_name(emitter.material);
    material.set_type(v1::Material::EMISSIVE);
    *material.mutable_radiance() = wire::encode_vec3(emitter.radiance.value_or(Vec3f{0, 0, 0}));
    material.set_off(emitter.off.value_or(false));
  }
  *header.mutable_camera() = wire::encode_camera(camera);
  *header.mutable_settings() = wire::encode_settings(settings);
  return header.SerializeAsString();
}

absl::Status decode_state(const std::string& bytes, const std::string& id, StoredScene* out) {
  v1::SceneHeader header;
  auto damaged = [&](const absl::Status& status) {
    return absl::DataLossError(
        absl::StrCat("scene index: the state of scene '", id, "' is damaged: ", status.message()));
  };
  if (!header.ParseFromString(bytes)) return damaged(absl::InvalidArgumentError("not a header"));
  absl::StatusOr<std::vector<Light>> lights = wire::decode_lights(header.lights(), "lights");
  if (!lights.ok()) return damaged(lights.status());
  absl::StatusOr<Camera> camera = wire::decode_camera(header.camera(), "camera");
  if (!camera.ok()) return damaged(camera.status());
  absl::StatusOr<RenderSettings> settings =
      wire::apply_settings(header.settings(), RenderSettings{}, "settings");
  if (!settings.ok()) return damaged(settings.status());
  out->emitters.clear();
  for (int i = 0; i < header.materials_size(); ++i) {
    const v1::Material& material = header.materials(i);
    absl::StatusOr<Vec3f> radiance =
        wire::decode_vec3(material.radiance(), absl::StrCat("materials[", i, "].radiance"));
    if (!radiance.ok()) return damaged(radiance.status());
    out->emitters.push_back({material.name(), *radiance, material.off()});
  }
  out->environment = {};
  if (header.has_environment()) {
    if (header.environment().has_intensity())
      out->environment.intensity = header.environment().intensity();
    out->environment.rotation_deg = header.environment().rotation_deg();
  }
  absl::StatusOr<std::vector<MeshChange>> placements =
      wire::decode_mesh_changes(header.placements(), "placements");
  if (!placements.ok()) return damaged(placements.status());
  out->placements = *std::move(placements);
  out->lights = *std::move(lights);
  out->camera = *camera;
  out->settings = *settings;
  return absl::OkStatus();
}

constexpr char kSchema[] = R"sql(
CREATE TABLE IF NOT EXISTS scenes (
  sequence INTEGER PRIMARY KEY AUTOINCREMENT,
  id TEXT NOT NULL UNIQUE,
  tenant TEXT NOT NULL,
  name TEXT NOT NULL,
  blob TEXT NOT NULL,
  state BLOB NOT NULL,
  epoch_geometry INTEGER NOT NULL,
  epoch_lights INTEGER NOT NULL,
  epoch_camera INTEGER NOT NULL,
  epoch_settings INTEGER NOT NULL,
  upload_bytes INTEGER NOT NULL,
  upload_ms REAL NOT NULL);
CREATE INDEX IF NOT EXISTS scenes_by_blob ON scenes(blob);
)sql";

}  // namespace

absl::StatusOr<std::unique_ptr<SceneStore>> SceneStore::open(
    const fs::path& dir, std::chrono::milliseconds update_sync_delay) {
  std::unique_ptr<SceneStore> store(new SceneStore());
  store->dir_ = dir;
  store->update_sync_delay_ = update_sync_delay;
  std::error_code error;
  fs::create_directories(dir / "blobs", error);
  if (!error) fs::create_directories(dir / "tmp", error);
  if (error) {
    return absl::InvalidArgumentError(
        absl::StrCat("--data-dir: cannot create ", dir.string(), ": ", error.message()));
  }
  const fs::path lock = dir / "lock";
  store->lock_fd_ = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (store->lock_fd_ < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--data-dir: cannot open ", lock.string(), ": ", errno_text()));
  }
  if (::flock(store->lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    return absl::FailedPreconditionError(absl::StrCat("--data-dir: ", dir.string(),
                                                      " is in use by another caustica-server (",
                                                      lock.string(), " is locked)"));
  }
  const fs::path index = dir / "index.db";
  // WAL keeps readers off the writer's way. The store's commits leave the log in the operating
  // system's cache (NORMAL), which a killed process does not lose; uploads and deletes sync it
  // themselves (FullSync), updates leave it to the syncer, whose connection syncs at FULL so that
  // its checkpoints put the log on the disk.
  if (absl::Status s = open_index(index, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE,
                                  {"PRAGMA journal_mode=WAL;", "PRAGMA synchronous=NORMAL;", kSchema},
                                  &store->db_);
      !s.ok()) {
    return s;
  }
  if (absl::Status s =
          open_index(index, SQLITE_OPEN_READWRITE, {"PRAGMA synchronous=FULL;"}, &store->sync_db_);
      !s.ok()) {
    return s;
  }
  if (absl::Status synced = fsync_path(dir, O_RDONLY | O_DIRECTORY); !synced.ok()) return synced;
  store->collect_garbage();
  store->syncer_ = std::thread([s = store.get()] { s->sync_updates(); });
  return store;
}

SceneStore::~SceneStore() {
  if (syncer_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closing_ = true;
    }
    sync_wake_.notify_all();
    syncer_.join();
  }
  if (sync_db_ != nullptr) sqlite3_close(sync_db_);
  if (db_ != nullptr) sqlite3_close(db_);
  if (lock_fd_ >= 0) ::close(lock_fd_);  // releases the lock
}

void SceneStore::sync_updates() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    sync_wake_.wait(lock, [&] { return closing_ || unsynced_since_.has_value(); });
    if (!closing_) {
      const auto due = *unsynced_since_ + update_sync_delay_;
      sync_wake_.wait_until(lock, due, [&] { return closing_; });
    }
    if (unsynced_since_) {
      const uint64_t covered = updates_;
      const auto started = std::chrono::steady_clock::now();
      lock.unlock();
      const absl::Status synced = exec_sql(sync_db_, "PRAGMA wal_checkpoint(PASSIVE);");
      lock.lock();
      if (!synced.ok()) {
        log_line(LogLevel::kError,
                 absl::StrCat("--data-dir: cannot sync the scene index: ", synced.message()));
      }
      // An update that committed while the checkpoint ran may have missed it: it gets one of
      // its own.
      if (updates_ == covered) {
        unsynced_since_.reset();
      } else {
        unsynced_since_ = started;
      }
    }
    if (closing_) return;
  }
}

bool SceneStore::sync_pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return unsynced_since_.has_value();
}

fs::path SceneStore::blob_path(const std::string& digest) const {
  return dir_ / "blobs" / (digest + ".scene");
}

absl::StatusOr<std::string> SceneStore::write_blob(const Scene& scene, const std::string& name) {
  std::string pattern = (dir_ / "tmp" / "blob-XXXXXX").string();
  const int fd = ::mkstemp(pattern.data());
  if (fd < 0) {
    return absl::InternalError(absl::StrCat("--data-dir: cannot create a file in ",
                                            (dir_ / "tmp").string(), ": ", errno_text()));
  }
  const fs::path temporary = pattern;
  auto fail = [&](absl::Status status) {
    ::close(fd);
    std::error_code ignored;
    fs::remove(temporary, ignored);
    return status;
  };
  Sha256 sha;
  std::string buffer(kBlobMagic, sizeof(kBlobMagic));
  v1::SceneChunk header;
  *header.mutable_header() = wire::encode_scene_header(scene, name);
  append_record(buffer, header);
  absl::Status written = absl::OkStatus();
  auto flush = [&] {
    sha.update(buffer);
    written = write_all(fd, buffer, temporary);
    buffer.clear();
    return written.ok();
  };
  wire::for_each_chunk(scene, wire::kMaxChunkBytes, [&](v1::SceneChunk& chunk) {
    append_record(buffer, chunk);
    return buffer.size() < (size_t{4} << 20) || flush();
  });
  if (!written.ok() || !flush()) return fail(written);
  if (::fsync(fd) != 0) {
    return fail(absl::InternalError(
        absl::StrCat("--data-dir: cannot sync ", temporary.string(), ": ", errno_text())));
  }
  ::close(fd);
  const std::string digest = sha.hex();
  std::error_code error;
  fs::rename(temporary, blob_path(digest), error);
  if (error) {
    fs::remove(temporary, error);
    return absl::InternalError(
        absl::StrCat("--data-dir: cannot store blob ", digest, ": ", error.message()));
  }
  if (absl::Status synced = fsync_path(dir_ / "blobs", O_RDONLY | O_DIRECTORY); !synced.ok()) {
    return synced;
  }
  return digest;
}

absl::StatusOr<Scene> SceneStore::read_blob(const std::string& digest) const {
  const fs::path path = blob_path(digest);
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::DataLossError(absl::StrCat("blob ", path.string(), " is missing"));
  auto damaged = [&](absl::string_view why) {
    return absl::DataLossError(absl::StrCat("blob ", path.string(), " is damaged: ", why));
  };
  Sha256 sha;
  char magic[sizeof(kBlobMagic)];
  if (!in.read(magic, sizeof(magic)) || std::memcmp(magic, kBlobMagic, sizeof(magic)) != 0) {
    return damaged("it does not start like a scene blob");
  }
  sha.update(std::string_view(magic, sizeof(magic)));
  wire::SceneAssembler assembler;
  std::string bytes;
  v1::SceneChunk chunk;
  for (size_t record = 0;; ++record) {
    unsigned char prefix[8];
    if (!in.read(reinterpret_cast<char*>(prefix), 8)) {
      if (in.gcount() == 0 && in.eof()) break;
      return damaged(absl::StrCat("record ", record, " is cut short"));
    }
    uint64_t length = 0;
    for (int i = 0; i < 8; ++i) length |= uint64_t{prefix[i]} << (8 * i);
    if (length > kMaxRecordBytes) return damaged(absl::StrCat("record ", record, " is too long"));
    bytes.resize(length);
    if (!in.read(bytes.data(), static_cast<std::streamsize>(length))) {
      return damaged(absl::StrCat("record ", record, " is cut short"));
    }
    sha.update(std::string_view(reinterpret_cast<const char*>(prefix), 8));
    sha.update(bytes);
    if (!chunk.ParseFromString(bytes))
      return damaged(absl::StrCat("record ", record, " does not parse"));
    if (absl::Status added = assembler.add(chunk); !added.ok()) return damaged(added.message());
  }
  if (sha.hex() != digest) return damaged("its contents do not match its SHA-256");
  absl::StatusOr<Scene> scene = assembler.finish();
  if (!scene.ok()) return damaged(scene.status().message());
  return scene;
}

bool SceneStore::blob_referenced(const std::string& digest) const {
  Statement query(db_, "SELECT 1 FROM scenes WHERE blob = ? LIMIT 1");
  if (!query.ok()) return true;  // when in doubt, keep the data
  query.bind_text(1, digest);
  const int step = query.step();
  return step != SQLITE_DONE;
}

void SceneStore::discard_blob(const std::string& digest) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (blob_referenced(digest)) return;
  std::error_code ignored;
  fs::remove(blob_path(digest), ignored);
}

absl::Status SceneStore::add(const StoredScene& scene) {
  std::lock_guard<std::mutex> lock(mutex_);
  const FullSync full(db_);
  if (!full.status().ok()) return full.status();
  Statement insert(db_,
                   "INSERT INTO scenes (id, tenant, name, blob, state, epoch_geometry, "
                   "epoch_lights, epoch_camera, epoch_settings, upload_bytes, upload_ms) "
                   "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  if (!insert.ok()) return insert.error("cannot prepare an insert");
  insert.bind_text(1, scene.id);
  insert.bind_text(2, scene.tenant);
  insert.bind_text(3, scene.name);
  insert.bind_text(4, scene.blob);
  insert.bind(5, encode_state(scene.lights, scene.emitters, scene.environment, scene.camera,
                              scene.settings, scene.placements));
  insert.bind(6, static_cast<int64_t>(scene.epochs.geometry));
  insert.bind(7, static_cast<int64_t>(scene.epochs.lights));
  insert.bind(8, static_cast<int64_t>(scene.epochs.camera));
  insert.bind(9, static_cast<int64_t>(scene.epochs.settings));
  insert.bind(10, static_cast<int64_t>(scene.upload_bytes));
  insert.bind(11, scene.upload_ms);
  if (insert.step() != SQLITE_DONE)
    return insert.error(absl::StrCat("cannot store scene ", scene.id));
  return absl::OkStatus();
}

absl::Status SceneStore::update(const std::string& id, const Scene& state,
                                const std::vector<MeshChange>& placements, const Epochs& epochs) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement update(db_,
                   "UPDATE scenes SET state = ?, epoch_geometry = ?, epoch_lights = ?, "
                   "epoch_camera = ?, epoch_settings = ? WHERE id = ?");
  if (!update.ok()) return update.error("cannot prepare an update");
  update.bind(
      1, encode_state(state.lights, emission_of(state.materials), environment_of(state.environment),
                      state.camera, state.settings, placements));
  update.bind(2, static_cast<int64_t>(epochs.geometry));
  update.bind(3, static_cast<int64_t>(epochs.lights));
  update.bind(4, static_cast<int64_t>(epochs.camera));
  update.bind(5, static_cast<int64_t>(epochs.settings));
  update.bind_text(6, id);
  // The commit is in the log (the operating system's cache) when step returns, which a killed
  // server does not lose; sync_updates puts it on the disk.
  if (update.step() != SQLITE_DONE) return update.error(absl::StrCat("cannot store scene ", id));
  ++updates_;
  if (!unsynced_since_) {
    unsynced_since_ = std::chrono::steady_clock::now();
    sync_wake_.notify_all();
  }
  return absl::OkStatus();
}

absl::Status SceneStore::remove(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  const FullSync full(db_);
  if (!full.status().ok()) return full.status();
  std::string blob;
  {
    Statement query(db_, "SELECT blob FROM scenes WHERE id = ?");
    if (!query.ok()) return query.error("cannot prepare a query");
    query.bind_text(1, id);
    if (query.step() != SQLITE_ROW) return absl::OkStatus();
    blob = query.text(0);
  }
  Statement erase(db_, "DELETE FROM scenes WHERE id = ?");
  if (!erase.ok()) return erase.error("cannot prepare a delete");
  erase.bind_text(1, id);
  if (erase.step() != SQLITE_DONE) return erase.error(absl::StrCat("cannot delete scene ", id));
  // The row is gone for good once the delete committed; a blob left by a crash here is garbage
  // the next start collects.
  if (!blob_referenced(blob)) {
    std::error_code ignored;
    fs::remove(blob_path(blob), ignored);
  }
  return absl::OkStatus();
}

absl::StatusOr<std::vector<StoredScene>> SceneStore::list() const {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement query(db_,
                  "SELECT id, tenant, name, blob, state, epoch_geometry, epoch_lights, "
                  "epoch_camera, epoch_settings, upload_bytes, upload_ms FROM scenes "
                  "ORDER BY sequence");
  if (!query.ok()) return query.error("cannot prepare a query");
  std::vector<StoredScene> out;
  int step;
  while ((step = query.step()) == SQLITE_ROW) {
    StoredScene& scene = out.emplace_back();
    scene.id = query.text(0);
    scene.tenant = query.text(1);
    scene.name = query.text(2);
    scene.blob = query.text(3);
    if (absl::Status decoded = decode_state(query.text(4), scene.id, &scene); !decoded.ok()) {
      return decoded;
    }
    scene.epochs = {
        static_cast<uint64_t>(query.integer(5)), static_cast<uint64_t>(query.integer(6)),
        static_cast<uint64_t>(query.integer(7)), static_cast<uint64_t>(query.integer(8))};
    scene.upload_bytes = static_cast<uint64_t>(query.integer(9));
    scene.upload_ms = query.real(10);
  }
  if (step != SQLITE_DONE) return query.error("cannot read the scenes");
  return out;
}

void SceneStore::collect_garbage() {
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_ / "tmp", error)) {
    std::error_code ignored;
    fs::remove_all(entry.path(), ignored);
  }
  size_t removed = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_ / "blobs", error)) {
    const fs::path path = entry.path();
    if (path.extension() != ".scene" || blob_referenced(path.stem().string())) continue;
    std::error_code ignored;
    if (fs::remove(path, ignored)) ++removed;
  }
  if (removed > 0) {
    log_line(LogLevel::kInfo, absl::StrCat("--data-dir: removed ", removed,
                                           " blob(s) of uploads that never completed"));
  }
}

Scene restored_scene(Scene geometry, const StoredScene& stored) {
  geometry.lights = stored.lights;
  for (const EmitterChange& emitter : stored.emitters) {
    for (Material& material : geometry.materials) {
      if (material.name != emitter.material || !is_emitter(material)) continue;
      material.radiance = emitter.radiance.value_or(material.radiance);
      material.off = emitter.off.value_or(material.off);
    }
  }
  if (geometry.environment.present) {
    Environment& e = geometry.environment;
    e.intensity = stored.environment.intensity.value_or(e.intensity);
    e.rotation_deg = stored.environment.rotation_deg.value_or(e.rotation_deg);
  }
  geometry.camera = stored.camera;
  geometry.settings = stored.settings;
  return geometry;
}

}  // namespace caustica::server
