// The scene's wire form: a loaded scene survives encode -> chunks -> assemble unchanged, and every
// kind of bad upload is refused at the chunk that breaks it, with the field named.
#include "proto/wire/scene_wire.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include "renderer/accel/build_options.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/scene/load_scene.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/validate.h"
#include "tests/renderer/grid_files.h"

namespace caustica::wire {
namespace {

using testing::HasSubstr;

Scene bundled(const char* name) {
  absl::StatusOr<Scene> scene =
      load_scene((std::filesystem::path(CAUSTICA_SCENES_DIR) / name / "scene.json").string());
  EXPECT_TRUE(scene.ok()) << scene.status();
  return scene.ok() ? *scene : Scene{};
}

std::vector<v1::SceneChunk> encode(const Scene& scene, size_t chunk_bytes) {
  std::vector<v1::SceneChunk> chunks(1);
  *chunks[0].mutable_header() = encode_scene_header(scene, "test");
  for_each_chunk(scene, chunk_bytes, [&](v1::SceneChunk& c) {
    chunks.push_back(c);
    return true;
  });
  return chunks;
}

// Feeds `chunks`; returns the first failure of add() or the result of finish().
absl::StatusOr<Scene> assemble(const std::vector<v1::SceneChunk>& chunks) {
  SceneAssembler assembler;
  for (const v1::SceneChunk& c : chunks) {
    if (absl::Status s = assembler.add(c); !s.ok()) return s;
  }
  return assembler.finish();
}

// Expects `chunks` after `edit` refused with `code`, its message holding `message`.
template <typename Edit>
void expect_refused(std::vector<v1::SceneChunk> chunks, Edit&& edit, const std::string& message,
                    absl::StatusCode code = absl::StatusCode::kInvalidArgument) {
  edit(chunks);
  const absl::Status status = assemble(chunks).status();
  EXPECT_EQ(status.code(), code) << message << ": " << status;
  EXPECT_THAT(std::string(status.message()), HasSubstr(message));
}

TEST(SceneWire, RoundTripKeepsEveryArrayExactly) {
  Scene scene = bundled("cornell-caustics");
  // Normals, texture coordinates, tangents and a mixed-material mesh exercise the optional
  // arrays.
  Mesh& textured = scene.meshes[0];
  textured.normals.assign(textured.positions.size(), Vec3f(0, 1, 0));
  for (size_t v = 0; v < textured.positions.size(); ++v) {
    textured.uvs.push_back({0.25f * float(v), 1.0f - 0.5f * float(v)});
    textured.tangents.push_back({1, 0, 0, v % 2 ? -1.0f : 1.0f});
  }
  scene.meshes[1].material_ids[0] = 1;
  std::vector<v1::SceneChunk> chunks = encode(scene, 4096);
  size_t data_bytes = 0;
  for (size_t i = 1; i < chunks.size(); ++i) {
    EXPECT_LE(chunks[i].mesh().data().size(), 4096u);
    data_bytes += chunks[i].mesh().data().size();
  }
  EXPECT_EQ(data_bytes, upload_bytes(scene));
  EXPECT_GT(chunks.size(), 10u);  // the spheres need several chunks at this size

  SceneAssembler assembler;
  for (const v1::SceneChunk& c : chunks) ASSERT_TRUE(assembler.add(c).ok());
  EXPECT_EQ(assembler.bytes_declared(), upload_bytes(scene));
  EXPECT_EQ(assembler.bytes_received(), upload_bytes(scene));
  absl::StatusOr<Scene> back = assembler.finish();
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->meshes.size(), scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& a = scene.meshes[m];
    const Mesh& b = back->meshes[m];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.indices, b.indices);
    EXPECT_EQ(a.material_ids, b.material_ids);
    ASSERT_EQ(a.positions.size(), b.positions.size());
    EXPECT_EQ(0, std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * 12));
    ASSERT_EQ(a.normals.size(), b.normals.size());
    ASSERT_EQ(a.uvs.size(), b.uvs.size());
    EXPECT_EQ(0, std::memcmp(a.uvs.data(), b.uvs.data(), a.uvs.size() * sizeof(Vec2f)));
    ASSERT_EQ(a.tangents.size(), b.tangents.size());
    EXPECT_EQ(0,
              std::memcmp(a.tangents.data(), b.tangents.data(), a.tangents.size() * sizeof(Vec4f)));
  }
  EXPECT_EQ(back->meshes[0].uvs.size(), textured.positions.size());
  EXPECT_EQ(back->meshes[0].tangents[1].w, -1.0f);
  ASSERT_EQ(back->materials.size(), scene.materials.size());
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    EXPECT_EQ(back->materials[i].name, scene.materials[i].name);
    EXPECT_EQ(back->materials[i].type, scene.materials[i].type);
    EXPECT_EQ(back->materials[i].color.x, scene.materials[i].color.x);
    EXPECT_EQ(back->materials[i].radiance.y, scene.materials[i].radiance.y);
    EXPECT_EQ(back->materials[i].ior, scene.materials[i].ior);
  }
  EXPECT_EQ(back->camera.width, scene.camera.width);
  EXPECT_EQ(back->camera.vertical_fov_deg, scene.camera.vertical_fov_deg);
  EXPECT_EQ(back->settings.photons_per_pass, scene.settings.photons_per_pass);
  EXPECT_EQ(back->settings.kernel, scene.settings.kernel);
  EXPECT_EQ(back->settings.structure, scene.settings.structure);
}

TEST(SceneWire, StructureRoundTripsThroughEncodeAndApply) {
  for (const StructureKind kind : kStructureKinds) {
    RenderSettings settings;
    settings.structure = kind;
    const v1::RenderSettings encoded = encode_settings(settings);
    EXPECT_NE(encoded.structure(), v1::STRUCTURE_UNSPECIFIED) << structure_kind_name(kind);
    // Applied on top of every other kind, so that the value comes from the wire.
    for (const StructureKind current : kStructureKinds) {
      RenderSettings before;
      before.structure = current;
      absl::StatusOr<RenderSettings> applied = apply_settings(encoded, before, "settings");
      ASSERT_TRUE(applied.ok()) << applied.status();
      EXPECT_EQ(applied->structure, kind) << structure_kind_name(kind);
    }
  }
  EXPECT_EQ(encode_structure(StructureKind::kLbvh4), v1::LBVH4);
  EXPECT_EQ(encode_structure(StructureKind::kBinnedSah), v1::BINNED_SAH);
  EXPECT_EQ(decode_structure(v1::LBVH4), StructureKind::kLbvh4);
  EXPECT_EQ(decode_structure(v1::BINNED_SAH), StructureKind::kBinnedSah);
  EXPECT_EQ(encode_structure(StructureKind::kHybrid), v1::HYBRID);
  EXPECT_EQ(decode_structure(v1::HYBRID), StructureKind::kHybrid);
  EXPECT_EQ(encode_structure(StructureKind::kSiblingPair), v1::SIBLING_PAIR);
  EXPECT_EQ(decode_structure(v1::SIBLING_PAIR), StructureKind::kSiblingPair);
  EXPECT_EQ(encode_structure(StructureKind::kDacrt), v1::DACRT);
  EXPECT_EQ(decode_structure(v1::DACRT), StructureKind::kDacrt);
  EXPECT_EQ(decode_structure(v1::STRUCTURE_UNSPECIFIED), std::nullopt);
}

TEST(SceneWire, VkdeAndItsSpreadRoundTrip) {
  RenderSettings settings;
  settings.estimator = EstimatorKind::kVkde;
  settings.vkde_spread = 3.5f;
  const v1::RenderSettings encoded = encode_settings(settings);
  EXPECT_EQ(encoded.estimator(), v1::VKDE);
  absl::StatusOr<RenderSettings> applied = apply_settings(encoded, RenderSettings{}, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_EQ(applied->estimator, EstimatorKind::kVkde);
  EXPECT_EQ(applied->vkde_spread, 3.5f);
  applied = apply_settings(v1::RenderSettings{}, settings, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_EQ(applied->vkde_spread, 3.5f);
}

TEST(SceneWire, FinalGatheringRoundTrips) {
  RenderSettings settings;
  settings.final_gather = true;
  settings.final_gather_rays = 64;
  settings.final_gather_seeds = 1024;
  const v1::RenderSettings encoded = encode_settings(settings);
  absl::StatusOr<RenderSettings> applied = apply_settings(encoded, RenderSettings{}, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_TRUE(applied->final_gather);
  EXPECT_EQ(applied->final_gather_rays, 64u);
  EXPECT_EQ(applied->final_gather_seeds, 1024u);
  v1::RenderSettings off;
  off.set_final_gather(false);
  applied = apply_settings(off, settings, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_FALSE(applied->final_gather);
  EXPECT_EQ(applied->final_gather_rays, 64u);
}

// The media, the scene's own medium and a mesh's interior survive the round trip.
TEST(SceneWire, MediaRoundTrip) {
  Scene scene = bundled("cornell-caustics");
  scene.media.push_back(
      {"fog", MediumType::kHomogeneous, Vec3f(0.1f, 0.2f, 0.3f), Vec3f(0.4f, 0.5f, 0.6f), -0.25f});
  scene.media.push_back({"mist", MediumType::kHomogeneous, Vec3f(0.0f), Vec3f(0.01f), 0.5f});
  scene.medium = 1;
  scene.meshes.back().interior_medium = 0;
  absl::StatusOr<Scene> back = assemble(encode(scene, 1 << 20));
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->media.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back->media[i].name, scene.media[i].name);
    EXPECT_EQ(back->media[i].type, scene.media[i].type);
    EXPECT_EQ(back->media[i].absorption, scene.media[i].absorption);
    EXPECT_EQ(back->media[i].scattering, scene.media[i].scattering);
    EXPECT_EQ(back->media[i].asymmetry, scene.media[i].asymmetry);
  }
  EXPECT_EQ(back->medium, 1u);
  EXPECT_EQ(back->meshes.back().interior_medium, 0u);
  EXPECT_EQ(back->meshes.front().interior_medium, kNoMedium);
  // No media at all stays none.
  back = assemble(encode(bundled("cornell-box"), 1 << 20));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(back->media.empty());
  EXPECT_EQ(back->medium, kNoMedium);
}

TEST(SceneWire, EstimatorSettingsRoundTripAndUnspecifiedKeepsTheCurrentOnes) {
  RenderSettings settings;
  settings.estimator = EstimatorKind::kSppm;
  settings.sppm_alpha = 0.5f;
  settings.sppm_radius = SppmRadius::kGlobal;
  const v1::RenderSettings encoded = encode_settings(settings);
  EXPECT_EQ(encoded.estimator(), v1::SPPM);
  absl::StatusOr<RenderSettings> applied = apply_settings(encoded, RenderSettings{}, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_EQ(applied->estimator, EstimatorKind::kSppm);
  EXPECT_EQ(applied->sppm_alpha, 0.5f);
  EXPECT_EQ(applied->sppm_radius, SppmRadius::kGlobal);
  // Unset fields keep what is in use.
  applied = apply_settings(v1::RenderSettings{}, settings, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_EQ(applied->estimator, EstimatorKind::kSppm);
  EXPECT_EQ(applied->sppm_radius, SppmRadius::kGlobal);
  v1::RenderSettings bad;
  bad.set_estimator(static_cast<v1::Estimator>(9));
  applied = apply_settings(bad, settings, "update.settings");
  ASSERT_FALSE(applied.ok());
  EXPECT_EQ(applied.status().message(), "update.settings.estimator: 9 is not an estimator");
  bad = v1::RenderSettings{};
  bad.set_sppm_radius(static_cast<v1::SppmRadius>(5));
  applied = apply_settings(bad, settings, "update.settings");
  ASSERT_FALSE(applied.ok());
  EXPECT_EQ(applied.status().message(), "update.settings.sppm_radius: 5 is not a radius rule");
}

TEST(SceneWire, IntegratorRoundTripsAndUnspecifiedKeepsTheCurrentOne) {
  for (const Integrator integrator : {Integrator::kPhoton, Integrator::kPath}) {
    RenderSettings settings;
    settings.integrator = integrator;
    const v1::RenderSettings encoded = encode_settings(settings);
    EXPECT_NE(encoded.integrator(), v1::INTEGRATOR_UNSPECIFIED);
    for (const Integrator current : {Integrator::kPhoton, Integrator::kPath}) {
      RenderSettings before;
      before.integrator = current;
      absl::StatusOr<RenderSettings> applied = apply_settings(encoded, before, "settings");
      ASSERT_TRUE(applied.ok()) << applied.status();
      EXPECT_EQ(applied->integrator, integrator);
    }
  }
  RenderSettings current;
  current.integrator = Integrator::kPath;
  v1::RenderSettings update;
  update.set_k_nearest(8);
  absl::StatusOr<RenderSettings> applied = apply_settings(update, current, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_EQ(applied->integrator, Integrator::kPath);
  update.set_integrator(static_cast<v1::Integrator>(7));
  applied = apply_settings(update, current, "update.settings");
  ASSERT_FALSE(applied.ok());
  EXPECT_EQ(applied.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(applied.status().message()),
              ::testing::HasSubstr("update.settings.integrator: 7 is not an integrator"));
}

// Each kind of a setting's table (scene/setting_kinds.h) has the proto's value of its number, named
// as the kind is (scene_wire.cc asserts at compile time that the numbers are the proto's), and
// round-trips through encode_settings and apply_settings.
// `field(settings)` is the setting's member in `settings`.
template <typename Field>
void expect_kinds_match_proto(const google::protobuf::EnumDescriptor& proto, Field field) {
  using Enum = std::remove_reference_t<decltype(field(std::declval<RenderSettings&>()))>;
  SCOPED_TRACE(proto.full_name());
  for (const SettingKind<Enum>& kind : SettingKinds<Enum>::kinds) {
    SCOPED_TRACE(kind.name);
    const google::protobuf::EnumValueDescriptor* value = proto.FindValueByNumber(int(kind.wire));
    ASSERT_NE(value, nullptr);
    std::string expected = kind.name;
    for (char& c : expected) c = c == '-' ? '_' : char(std::toupper(static_cast<unsigned char>(c)));
    // The proto's names carry a prefix where the bare name would clash (SPPM_RADIUS_PIXEL).
    EXPECT_TRUE(value->name() == expected || value->name().ends_with("_" + expected))
        << value->name() << " against " << expected;
    RenderSettings settings;
    Enum& member = field(settings);
    member = kind.value;
    absl::StatusOr<RenderSettings> back =
        apply_settings(encode_settings(settings), RenderSettings{}, "settings");
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_EQ(field(*back), kind.value);
  }
}

TEST(SceneWire, SettingKindsAreTheProtosValuesByName) {
  expect_kinds_match_proto(
      *v1::Integrator_descriptor(), [](RenderSettings & s) -> auto& { return s.integrator; });
  expect_kinds_match_proto(
      *v1::Estimator_descriptor(), [](RenderSettings & s) -> auto& { return s.estimator; });
  expect_kinds_match_proto(
      *v1::SppmRadius_descriptor(), [](RenderSettings & s) -> auto& { return s.sppm_radius; });
  expect_kinds_match_proto(
      *v1::DensityKernel_descriptor(), [](RenderSettings & s) -> auto& { return s.kernel; });
  expect_kinds_match_proto(
      *v1::BinnedSahReorder_descriptor(),
      [](RenderSettings & s) -> auto& { return s.build.binned_sah.reorder; });
  expect_kinds_match_proto(
      *v1::KdTraversal_descriptor(),
      [](RenderSettings & s) -> auto& { return s.build.kd_traversal; });
  expect_kinds_match_proto(
      *v1::Refit_descriptor(), [](RenderSettings & s) -> auto& { return s.build.refit; });
}

// The schedule of a text the test knows is good.
BinnedSahSchedule schedule_of(std::string_view text,
                              BinnedSahReorder reorder = BinnedSahReorder::kRadixSort) {
  BinnedSahSchedule schedule;
  schedule.reorder = reorder;
  const std::optional<std::string> problem = parse_binned_sah_stages(text, schedule);
  EXPECT_FALSE(problem) << problem.value_or("");
  return schedule;
}

// settings.build through the wire: every stage and both kinds; an empty list and unset kinds keep
// the current ones; a list longer than a schedule holds is refused by name (the values are
// validate_settings', which names the stage).
TEST(SceneWire, BuildOptionsRoundTripAndUnsetKeepsTheCurrentOnes) {
  RenderSettings settings;
  settings.build.binned_sah = schedule_of("65536:128,4096:32,64:8");
  settings.build.binned_sah.reorder = BinnedSahReorder::kSegmentedSplits;
  settings.build.kd_traversal = KdTraversal::kStackless;
  settings.build.refit = RefitPolicy::kAlways;
  settings.build.refit_sah_bound = 2.5f;
  const v1::RenderSettings encoded = encode_settings(settings);
  ASSERT_EQ(encoded.build().binned_sah_stages_size(), 3);
  EXPECT_EQ(encoded.build().binned_sah_stages(1).above(), 4096u);
  EXPECT_EQ(encoded.build().binned_sah_stages(1).bins(), 32u);
  absl::StatusOr<RenderSettings> applied = apply_settings(encoded, RenderSettings{}, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_EQ(applied->build, settings.build);
  applied = apply_settings(v1::RenderSettings{}, settings, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_EQ(applied->build, settings.build);

  // A shorter list replaces the whole schedule, the stages past it cleared.
  v1::RenderSettings shorter;
  v1::BinnedSahStage& stage = *shorter.mutable_build()->add_binned_sah_stages();
  stage.set_above(256);
  stage.set_bins(16);
  applied = apply_settings(shorter, settings, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_EQ(applied->build.binned_sah, schedule_of("256:16", BinnedSahReorder::kSegmentedSplits));

  v1::RenderSettings too_many;
  for (int i = 0; i <= kMaxBinnedSahStages; ++i) {
    v1::BinnedSahStage& s = *too_many.mutable_build()->add_binned_sah_stages();
    s.set_above(10000 - 100 * i);
    s.set_bins(2);
  }
  applied = apply_settings(too_many, settings, "update.settings");
  EXPECT_EQ(applied.status().message(),
            "update.settings.build.binned_sah_stages: 7 stages; at most 6");
  v1::RenderSettings bad;
  bad.mutable_build()->set_kd_traversal(static_cast<v1::KdTraversal>(3));
  applied = apply_settings(bad, settings, "update.settings");
  EXPECT_EQ(applied.status().message(),
            "update.settings.build.kd_traversal: 3 is not a kd-tree traversal");
  bad = v1::RenderSettings{};
  bad.mutable_build()->set_refit(static_cast<v1::Refit>(4));
  applied = apply_settings(bad, settings, "update.settings");
  EXPECT_EQ(applied.status().message(), "update.settings.build.refit: 4 is not a refit policy");
}

TEST(SceneWire, UnspecifiedStructureKeepsTheCurrentOne) {
  RenderSettings current;
  current.structure = StructureKind::kBinnedSah;
  v1::RenderSettings update;
  update.set_k_nearest(8);
  ASSERT_EQ(update.structure(), v1::STRUCTURE_UNSPECIFIED);
  absl::StatusOr<RenderSettings> applied = apply_settings(update, current, "settings");
  ASSERT_TRUE(applied.ok()) << applied.status();
  EXPECT_EQ(applied->structure, StructureKind::kBinnedSah);
  EXPECT_EQ(applied->k_nearest, 8u);
}

TEST(SceneWire, UnknownStructureIsRefusedNamingTheField) {
  v1::RenderSettings update;
  update.set_structure(static_cast<v1::Structure>(99));
  absl::StatusOr<RenderSettings> applied = apply_settings(update, RenderSettings{}, "settings");
  EXPECT_EQ(applied.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(applied.status().message()),
              HasSubstr("settings.structure: 99 is not a structure"));
}

TEST(SceneWire, ChunkChecksumIsZlibCrc32) {
  EXPECT_EQ(chunk_crc32("123456789"), 0xCBF43926u);  // the standard CRC-32 check value
  EXPECT_EQ(chunk_crc32(""), 0u);
}

TEST(SceneWire, LightsAndSettingsRoundTrip) {
  Light spot{"spot", LightType::kSpot, Vec3f(1, 2, 3), Vec3f(0, -1, 0), Vec3f(4, 5, 6), 10, 20};
  absl::StatusOr<Light> back = decode_light(encode_light(spot), "lights[0]");
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->type, LightType::kSpot);
  EXPECT_EQ(back->position.z, 3.0f);
  EXPECT_EQ(back->outer_angle_deg, 20.0f);

  RenderSettings current;
  v1::RenderSettings update;
  update.set_k_nearest(16);
  absl::StatusOr<RenderSettings> applied = apply_settings(update, current, "settings");
  ASSERT_TRUE(applied.ok());
  EXPECT_EQ(applied->k_nearest, 16u);
  EXPECT_EQ(applied->photons_per_pass, current.photons_per_pass);  // unset fields stay
}

// A keyframe's camera carries no size: decode_camera_at reads the rest and gives the camera the
// size it is told, whatever the message holds there, while decode_camera refuses a size of 0.
TEST(SceneWire, ACameraWithoutASizeTakesTheOneItIsGiven) {
  Camera camera;
  camera.position = Vec3f(1, 2, 3);
  camera.look_at = Vec3f(0, 1, 0);
  camera.up = Vec3f(0, 0, 1);
  camera.vertical_fov_deg = 35;
  camera.width = 64;
  camera.height = 48;
  v1::Camera message = encode_camera(camera);
  message.clear_width();
  message.clear_height();
  const absl::StatusOr<Camera> at = decode_camera_at(message, "keyframes[2].camera", 320, 240);
  ASSERT_TRUE(at.ok()) << at.status();
  EXPECT_EQ(at->position, camera.position);
  EXPECT_EQ(at->look_at, camera.look_at);
  EXPECT_EQ(at->up, camera.up);
  EXPECT_EQ(at->vertical_fov_deg, 35.0f);
  EXPECT_EQ(at->width, 320);
  EXPECT_EQ(at->height, 240);
  const absl::StatusOr<Camera> sized = decode_camera(message, "camera");
  ASSERT_FALSE(sized.ok());
  EXPECT_THAT(std::string(sized.status().message()), HasSubstr("camera.width: 0 is outside"));
  message.mutable_position()->set_x(std::nanf(""));
  const absl::StatusOr<Camera> bad = decode_camera_at(message, "keyframes[2].camera", 320, 240);
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(std::string(bad.status().message()), HasSubstr("keyframes[2].camera.position"));
}

// An environment arrives with its map, colour, intensity and rotation; a scene without one has
// none; a map that names no texture is refused by name.
TEST(SceneWire, EnvironmentRoundTrips) {
  Scene scene = bundled("cornell-box");
  absl::StatusOr<Scene> back = assemble(encode(scene, 1 << 20));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_FALSE(back->environment.present);
  scene.environment = {
      .present = true, .color = {0.5f, 0.25f, 1.0f}, .intensity = 2.5f, .rotation_deg = -30.0f};
  back = assemble(encode(scene, 1 << 20));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(back->environment.present);
  EXPECT_EQ(back->environment.texture, kNoTexture);
  EXPECT_EQ(back->environment.color, scene.environment.color);
  EXPECT_EQ(back->environment.intensity, 2.5f);
  EXPECT_EQ(back->environment.rotation_deg, -30.0f);

  v1::Environment wire;
  wire.set_texture(3);
  const absl::StatusOr<Environment> refused = decode_environment(wire, 2);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(std::string(refused.status().message()), HasSubstr("environment.texture"));
  wire.set_texture(2);
  const absl::StatusOr<Environment> second = decode_environment(wire, 2);
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(second->texture, 1u);
  EXPECT_EQ(second->intensity, 1.0f);     // unset: 1
  EXPECT_EQ(second->color, Vec3f(1.0f));  // unset: white
}

// The metallic-roughness and Phong models and a rough dielectric arrive with every field they
// carry; a mirror keeps the fields it does not use too.
TEST(SceneWire, MetallicRoughnessPhongAndRoughGlassRoundTrip) {
  Scene scene = bundled("cornell-box");
  scene.materials.push_back({.name = "steel",
                             .type = MaterialType::kMetallicRoughness,
                             .color = {0.9f, 0.8f, 0.7f},
                             .metallic = 0.75f,
                             .roughness = 0.25f});
  scene.materials.push_back({.name = "plastic",
                             .type = MaterialType::kPhong,
                             .color = {0.5f, 0.4f, 0.3f},
                             .specular = {0.125f, 0.25f, 0.375f},
                             .exponent = 42.5f,
                             .radiance = {1, 2, 3}});
  scene.materials.push_back(
      {.name = "frosted", .type = MaterialType::kDielectric, .ior = 1.33f, .roughness = 0.6f});
  scene.meshes[0].material_ids.assign(scene.meshes[0].triangle_count(),
                                      uint32_t(scene.materials.size() - 2));
  absl::StatusOr<Scene> back = assemble(encode(scene, 1 << 20));
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->materials.size(), scene.materials.size());
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const Material& a = scene.materials[i];
    const Material& b = back->materials[i];
    SCOPED_TRACE(a.name);
    EXPECT_EQ(b.name, a.name);
    EXPECT_EQ(b.type, a.type);
    EXPECT_EQ(b.color, a.color);
    EXPECT_EQ(b.ior, a.ior);
    EXPECT_EQ(b.metallic, a.metallic);
    EXPECT_EQ(b.roughness, a.roughness);
    EXPECT_EQ(b.specular, a.specular);
    EXPECT_EQ(b.exponent, a.exponent);
    EXPECT_EQ(b.radiance, a.radiance);
  }
  const v1::Material steel = encode_material(scene.materials.at(scene.materials.size() - 3));
  EXPECT_EQ(steel.type(), v1::Material::METALLIC_ROUGHNESS);
  EXPECT_EQ(steel.metallic(), 0.75f);
  EXPECT_EQ(steel.roughness(), 0.25f);
  const v1::Material plastic = encode_material(scene.materials.at(scene.materials.size() - 2));
  EXPECT_EQ(plastic.type(), v1::Material::PHONG);
  EXPECT_EQ(plastic.specular().z(), 0.375f);
  EXPECT_EQ(plastic.exponent(), 42.5f);
  EXPECT_EQ(back->meshes[0].material_ids.front(), scene.materials.size() - 2);
  EXPECT_TRUE(validate_scene(*back).ok()) << validate_scene(*back);
}

struct BadUpload {
  const char* what;
  std::function<void(std::vector<v1::SceneChunk>&)> corrupt;
  absl::StatusCode code;
  const char* message;
  bool textured = false;  // every mesh with normals, texture coordinates and tangents
};

class SceneWireRefuses : public testing::TestWithParam<BadUpload> {};

// cornell-box with every mesh carrying normals, texture coordinates and tangents.
Scene textured_box() {
  Scene scene = bundled("cornell-box");
  for (Mesh& mesh : scene.meshes) {
    mesh.normals.assign(mesh.positions.size(), Vec3f(0, 0, 1));
    mesh.uvs.assign(mesh.positions.size(), Vec2f{0.5f, 0.5f});
    mesh.tangents.assign(mesh.positions.size(), Vec4f{1, 0, 0, 1});
  }
  return scene;
}

TEST_P(SceneWireRefuses, NamingTheProblem) {
  std::vector<v1::SceneChunk> chunks =
      encode(GetParam().textured ? textured_box() : bundled("cornell-box"), 1 << 20);
  GetParam().corrupt(chunks);
  absl::StatusOr<Scene> result = assemble(chunks);
  EXPECT_EQ(result.status().code(), GetParam().code) << result.status();
  EXPECT_THAT(std::string(result.status().message()), HasSubstr(GetParam().message));
}

v1::MeshChunk& first_chunk_of(std::vector<v1::SceneChunk>& chunks, v1::MeshChunk::Array array) {
  for (v1::SceneChunk& c : chunks)
    if (c.has_mesh() && c.mesh().array() == array) return *c.mutable_mesh();
  throw std::runtime_error("no such chunk");
}

void rewrite(v1::MeshChunk& chunk, size_t byte, const void* value, size_t size) {
  std::string data = chunk.data();
  std::memcpy(data.data() + byte, value, size);
  chunk.set_data(data);
  chunk.set_crc32(chunk_crc32(data));
}

INSTANTIATE_TEST_SUITE_P(
    BadChunks, SceneWireRefuses,
    testing::Values(
        BadUpload{"bad checksum",
                  [](auto& c) { first_chunk_of(c, v1::MeshChunk::POSITIONS).set_crc32(1); },
                  absl::StatusCode::kInvalidArgument, "mesh.crc32"},
        BadUpload{"offset gap",
                  [](auto& c) { first_chunk_of(c, v1::MeshChunk::INDICES).set_offset(12); },
                  absl::StatusCode::kInvalidArgument, "offset 12 but 0 bytes arrived"},
        BadUpload{"chunk before header", [](auto& c) { std::swap(c[0], c[1]); },
                  absl::StatusCode::kInvalidArgument,
                  "chunk 0: mesh: arrives before the scene header"},
        BadUpload{"partial element",
                  [](auto& c) {
                    v1::MeshChunk& m = first_chunk_of(c, v1::MeshChunk::POSITIONS);
                    m.set_data(m.data().substr(0, 10));
                    m.set_crc32(chunk_crc32(m.data()));
                  },
                  absl::StatusCode::kInvalidArgument, "not a whole number of 12-byte elements"},
        BadUpload{"oversized chunk",
                  [](auto& c) {
                    v1::MeshChunk& m = first_chunk_of(c, v1::MeshChunk::POSITIONS);
                    m.set_data(std::string(kMaxChunkBytes + 12, '\0'));
                    m.set_crc32(chunk_crc32(m.data()));
                  },
                  absl::StatusCode::kInvalidArgument, "chunk limit"},
        BadUpload{"counts disagree",
                  [](auto& c) {
                    v1::MeshHeader* h = c[0].mutable_header()->mutable_meshes(0);
                    h->set_triangle_count(h->triangle_count() + 1);
                  },
                  absl::StatusCode::kInvalidArgument,
                  "indices has 24 bytes but the header declares 36"},
        BadUpload{"medium type unspecified",
                  [](auto& c) {
                    v1::Medium* m = c[0].mutable_header()->add_media();
                    m->set_name("fog");
                  },
                  absl::StatusCode::kInvalidArgument, "media[0].type: 0 is not a medium type"},
        BadUpload{"scene medium out of range",
                  [](auto& c) { c[0].mutable_header()->set_medium(1); },
                  absl::StatusCode::kInvalidArgument,
                  "medium: 1 names no medium (the scene has 0 media; 1 is the first, 0 none)"},
        BadUpload{"mesh medium out of range",
                  [](auto& c) { c[0].mutable_header()->mutable_meshes(0)->set_interior_medium(3); },
                  absl::StatusCode::kInvalidArgument, "interior_medium: 3 names no medium"},
        BadUpload{"index out of range",
                  [](auto& c) {
                    uint32_t bad = 99;
                    rewrite(first_chunk_of(c, v1::MeshChunk::INDICES), 4, &bad, 4);
                  },
                  absl::StatusCode::kInvalidArgument, "triangle 0 refers to vertex 99 of 4"},
        BadUpload{"NaN vertex",
                  [](auto& c) {
                    float nan = std::nanf("");
                    rewrite(first_chunk_of(c, v1::MeshChunk::POSITIONS), 16, &nan, 4);
                  },
                  absl::StatusCode::kInvalidArgument, "vertex 1 is (0, nan, 0), not finite"},
        BadUpload{"resolution 0",
                  [](auto& c) { c[0].mutable_header()->mutable_camera()->set_width(0); },
                  absl::StatusCode::kInvalidArgument, "camera.width: 0 is outside [1, 16384]"},
        BadUpload{"resolution 100000",
                  [](auto& c) { c[0].mutable_header()->mutable_camera()->set_height(100000); },
                  absl::StatusCode::kInvalidArgument, "camera.height: 100000 is outside"},
        BadUpload{"absurd size",
                  [](auto& c) {
                    c[0].mutable_header()->mutable_meshes(0)->set_vertex_count(uint64_t{1} << 40);
                  },
                  absl::StatusCode::kResourceExhausted, "vertex_count: 1099511627776 exceeds"},
        BadUpload{"too many triangles in all",
                  [](auto& c) {
                    // Each mesh within the per-mesh limit, together over the scene's: refused at
                    // the header, before anything the size of the declared meshes is allocated.
                    v1::SceneHeader* h = c[0].mutable_header();
                    for (int i = 0; i < 8; ++i) {
                      v1::MeshHeader* m = h->add_meshes();
                      *m = h->meshes(0);
                      m->set_triangle_count(kMaxTrianglesPerMesh);
                      m->set_vertex_count(3);
                    }
                  },
                  absl::StatusCode::kResourceExhausted,
                  "alone, more than the limit of 268435456 per scene"},
        BadUpload{"unknown material type",
                  [](auto& c) {
                    c[0].mutable_header()->mutable_materials(0)->set_type(
                        v1::Material::TYPE_UNSPECIFIED);
                  },
                  absl::StatusCode::kInvalidArgument, "materials[0].type"},
        BadUpload{"material type beyond the known ones",
                  [](auto& c) {
                    c[0].mutable_header()->mutable_materials(0)->set_type(
                        static_cast<v1::Material::Type>(7));
                  },
                  absl::StatusCode::kInvalidArgument,
                  "materials[0].type: 7 is not a material type"},
        BadUpload{
            "specular not finite",
            [](auto& c) {
              c[0].mutable_header()->mutable_materials(0)->mutable_specular()->set_y(std::nanf(""));
            },
            absl::StatusCode::kInvalidArgument, "materials[0].specular: (0, nan, 0) is not finite"},
        BadUpload{"material out of range",
                  [](auto& c) { c[0].mutable_header()->mutable_meshes(0)->set_material(42); },
                  absl::StatusCode::kInvalidArgument, "material: 42 is out of range"},
        BadUpload{"unknown structure",
                  [](auto& c) {
                    c[0].mutable_header()->mutable_settings()->set_structure(
                        static_cast<v1::Structure>(99));
                  },
                  absl::StatusCode::kInvalidArgument, "settings.structure"},
        BadUpload{"no header at all", [](auto& c) { c.clear(); },
                  absl::StatusCode::kInvalidArgument, "ended before the scene header"},
        BadUpload{"second header", [](auto& c) { c.push_back(c[0]); },
                  absl::StatusCode::kInvalidArgument, "a second header"},
        BadUpload{"tangent w not a sign",
                  [](auto& c) {
                    float half = 0.5f;
                    rewrite(first_chunk_of(c, v1::MeshChunk::TANGENTS), 16 + 12, &half, 4);
                  },
                  absl::StatusCode::kInvalidArgument,
                  "tangents: vertex 1 is (1, 0, 0, 0.5) has w = 0.5, not 1 or -1", true},
        BadUpload{"NaN texture coordinate",
                  [](auto& c) {
                    float nan = std::nanf("");
                    rewrite(first_chunk_of(c, v1::MeshChunk::TEXCOORDS), 8, &nan, 4);
                  },
                  absl::StatusCode::kInvalidArgument,
                  "texcoords: vertex 1 is (nan, 0.5), not finite", true},
        BadUpload{"tangents without normals",
                  [](auto& c) { c[0].mutable_header()->mutable_meshes(0)->set_has_normals(false); },
                  absl::StatusCode::kInvalidArgument, "has_tangents: is set without has_normals",
                  true},
        BadUpload{"texture coordinates declared but not sent",
                  [](auto& c) {
                    std::erase_if(c, [](const v1::SceneChunk& chunk) {
                      return chunk.has_mesh() && chunk.mesh().array() == v1::MeshChunk::TEXCOORDS;
                    });
                  },
                  absl::StatusCode::kInvalidArgument,
                  "texcoords has 0 bytes but the header declares 32 (8 per element)", true}),
    [](const testing::TestParamInfo<BadUpload>& info) {
      std::string name = info.param.what;
      for (char& ch : name)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      return name;
    });

// fog-box with its fog a grid medium: a 12^3 block of rising density, turned and moved.
Scene with_grid_fog() {
  Scene scene = bundled("fog-box");
  Medium& fog = scene.media.at(0);
  fog.type = MediumType::kGrid;
  fog.grid = test_grids::grid_bytes(test_grids::density_grid(
      12, 0.5, nanovdb::Vec3d(1.0), [](int i, int j, int k) { return 0.01f * (i + j + k); }));
  fog.grid_source = "block.nvdb";
  fog.grid_to_scene = Affine{};
  fog.grid_to_scene.m[0] = {0.0, -40.0, 0.0, 270.0};
  fog.grid_to_scene.m[1] = {40.0, 0.0, 0.0, 10.0};
  fog.grid_to_scene.m[2] = {0.0, 0.0, 40.0, 30.0};
  return scene;
}

TEST(SceneWire, AGridMediumArrivesByteForByteWithItsPlacement) {
  const Scene scene = with_grid_fog();
  const std::vector<v1::SceneChunk> chunks = encode(scene, 4096);
  size_t grid_chunks = 0;
  for (const v1::SceneChunk& c : chunks) {
    if (!c.has_grid()) continue;
    EXPECT_LE(c.grid().data().size(), 4096u);
    ++grid_chunks;
  }
  EXPECT_EQ(grid_chunks, (scene.media[0].grid->size() + 4095) / 4096);
  absl::StatusOr<Scene> back = assemble(chunks);
  ASSERT_TRUE(back.ok()) << back.status();
  const Medium& a = scene.media[0];
  const Medium& b = back->media.at(0);
  EXPECT_EQ(b.type, MediumType::kGrid);
  EXPECT_EQ(b.grid_source, "block.nvdb");
  EXPECT_EQ(b.grid_to_scene.m, a.grid_to_scene.m);
  ASSERT_NE(b.grid, nullptr);
  ASSERT_EQ(b.grid->size(), a.grid->size());
  EXPECT_EQ(0, std::memcmp(b.grid->data(), a.grid->data(), a.grid->size()));
  EXPECT_EQ(reinterpret_cast<uintptr_t>(b.grid->data()) % 32, 0u);
}

TEST(SceneWire, BadGridChunksAreRefusedNamingTheirField) {
  const Scene scene = with_grid_fog();
  const std::vector<v1::SceneChunk> good = encode(scene, 4096);
  size_t first_grid = 0;
  while (!good[first_grid].has_grid()) ++first_grid;
  auto fails_with = [&](auto&& edit, const std::string& message) {
    expect_refused(good, edit, message);
  };
  fails_with([&](auto& c) { c[first_grid].mutable_grid()->set_medium(3); },
             "grid.medium: 3 is not a GRID medium's index");
  fails_with([&](auto& c) { c[first_grid].mutable_grid()->set_crc32(1); },
             "grid.crc32: medium 'fog' grid: checksum");
  fails_with([&](auto& c) { std::swap(c[first_grid], c[first_grid + 1]); },
             "grid.offset: medium 'fog' grid: offset 4096 but 0 bytes arrived so far");
  fails_with([&](auto& c) { c.pop_back(); }, "media[0] 'fog': grid has");
  fails_with([&](auto& c) { c[0].mutable_header()->mutable_media(0)->set_grid_bytes(0); },
             "media[0].grid_bytes: is 0");
  fails_with([&](auto& c) { c[0].mutable_header()->mutable_media(0)->add_grid_to_scene(1.0); },
             "media[0].grid_to_scene: has 13 numbers; it takes 12");
  fails_with(
      [&](auto& c) { c[0].mutable_header()->mutable_media(0)->set_grid_to_scene(5, std::nan("")); },
      "media[0].grid_to_scene: number 5 is nan, not finite");
  fails_with(
      [&](auto& c) { c[0].mutable_header()->mutable_media(0)->set_type(v1::Medium::HOMOGENEOUS); },
      "media[0].grid_bytes: a HOMOGENEOUS medium carries no grid");
  // A grid larger than the limit is refused from its header, before anything is allocated.
  std::vector<v1::SceneChunk> huge = good;
  huge[0].mutable_header()->mutable_media(0)->set_grid_bytes(kMaxGridBytes + 1);
  EXPECT_EQ(assemble(huge).status().code(), absl::StatusCode::kResourceExhausted);
}

// A cornell box whose white material reads a texture over a second file and whose light reads an
// emission map, with bytes that need not be an image: the wire carries files, not pixels.
Scene with_textures() {
  Scene scene = bundled("cornell-box");
  std::string first(5000, '\0');
  for (size_t i = 0; i < first.size(); ++i) first[i] = static_cast<char>(i * 7 + 3);
  scene.textures.push_back({"wood.png", std::make_shared<const std::string>(first), nullptr});
  scene.textures.push_back({"glow.jpg", std::make_shared<const std::string>("tiny"), nullptr});
  Material& white = scene.materials.at(0);
  white.color_map.texture = 0;
  white.color_map.wrap_u = TextureWrap::kMirroredRepeat;
  white.color_map.wrap_v = TextureWrap::kClampToEdge;
  white.color_map.transform = {{0.25f, -0.5f}, 0.3f, {2.0f, 3.0f}};
  scene.materials.at(1).emission_map.texture = 1;
  Material& red = scene.materials.at(2);
  red.type = MaterialType::kMetallicRoughness;
  red.metallic_roughness_map.texture = 1;
  red.metallic_roughness_map.wrap_u = TextureWrap::kClampToEdge;
  red.normal_map.texture = 0;
  red.normal_scale = 0.5f;
  Material& fourth = scene.materials.at(3);
  fourth.alpha_mode = AlphaMode::kMask;
  fourth.alpha_cutoff = 0.25f;
  fourth.opacity = 0.75f;
  fourth.opacity_map.texture = 1;
  fourth.bump_map.texture = 0;
  fourth.bump_scale = 3.0f;
  Material separate;
  separate.name = "separate";
  separate.type = MaterialType::kMetallicRoughness;
  separate.roughness_map.texture = 0;
  separate.metallic_map.texture = 1;
  scene.materials.push_back(separate);
  return scene;
}

TEST(SceneWire, TexturesArriveByteForByteWithTheirMaps) {
  const Scene scene = with_textures();
  const std::vector<v1::SceneChunk> chunks = encode(scene, 1024);
  size_t texture_chunks = 0;
  for (const v1::SceneChunk& c : chunks) texture_chunks += c.has_texture();
  EXPECT_EQ(texture_chunks, 5u + 1u);  // 5000 bytes in 1024-byte chunks, then 4 bytes
  EXPECT_EQ(upload_bytes(scene) - upload_bytes(bundled("cornell-box")), 5004u);
  absl::StatusOr<Scene> back = assemble(chunks);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->textures.size(), 2u);
  for (size_t t = 0; t < 2; ++t) {
    EXPECT_EQ(back->textures[t].name, scene.textures[t].name);
    ASSERT_NE(back->textures[t].encoded, nullptr);
    EXPECT_EQ(*back->textures[t].encoded, *scene.textures[t].encoded);
    EXPECT_EQ(back->textures[t].decoded, nullptr);
  }
  const TextureRef& map = back->materials.at(0).color_map;
  EXPECT_EQ(map.texture, 0u);
  EXPECT_EQ(map.wrap_u, TextureWrap::kMirroredRepeat);
  EXPECT_EQ(map.wrap_v, TextureWrap::kClampToEdge);
  EXPECT_EQ(map.transform.offset.x, 0.25f);
  EXPECT_EQ(map.transform.offset.y, -0.5f);
  EXPECT_EQ(map.transform.rotation, 0.3f);
  EXPECT_EQ(map.transform.scale.x, 2.0f);
  EXPECT_EQ(map.transform.scale.y, 3.0f);
  EXPECT_FALSE(back->materials.at(0).emission_map.used());
  EXPECT_EQ(back->materials.at(1).emission_map.texture, 1u);
  EXPECT_FALSE(back->materials.at(2).color_map.used());
  EXPECT_EQ(back->materials.at(2).metallic_roughness_map.texture, 1u);
  EXPECT_EQ(back->materials.at(2).metallic_roughness_map.wrap_u, TextureWrap::kClampToEdge);
  EXPECT_FALSE(back->materials.at(0).metallic_roughness_map.used());
  EXPECT_EQ(back->materials.at(2).normal_map.texture, 0u);
  EXPECT_EQ(back->materials.at(2).normal_scale, 0.5f);
  EXPECT_FALSE(back->materials.at(0).normal_map.used());
  EXPECT_EQ(back->materials.at(0).normal_scale, 1.0f);
  const Material& fourth = back->materials.at(3);
  EXPECT_EQ(fourth.alpha_mode, AlphaMode::kMask);
  EXPECT_EQ(fourth.alpha_cutoff, 0.25f);
  EXPECT_EQ(fourth.opacity, 0.75f);
  EXPECT_EQ(fourth.opacity_map.texture, 1u);
  EXPECT_EQ(back->materials.at(0).alpha_mode, AlphaMode::kOpaque);
  EXPECT_EQ(back->materials.at(0).opacity, 1.0f);
  EXPECT_EQ(back->materials.at(0).alpha_cutoff, 0.5f);
  EXPECT_FALSE(back->materials.at(0).opacity_map.used());
  EXPECT_EQ(fourth.bump_map.texture, 0u);
  EXPECT_EQ(fourth.bump_scale, 3.0f);
  EXPECT_FALSE(back->materials.at(0).bump_map.used());
  EXPECT_EQ(back->materials.at(0).bump_scale, 1.0f);
  const Material& separate = back->materials.back();
  EXPECT_EQ(separate.roughness_map.texture, 0u);
  EXPECT_EQ(separate.metallic_map.texture, 1u);
  EXPECT_FALSE(separate.metallic_roughness_map.used());
  EXPECT_TRUE(validate_scene(*back).ok());
}

TEST(SceneWire, BadTexturesAreRefusedNamingTheirField) {
  const std::vector<v1::SceneChunk> good = encode(with_textures(), 1024);
  size_t first = 0;
  while (!good[first].has_texture()) ++first;
  auto fails_with = [&](auto&& edit, const std::string& message,
                        absl::StatusCode code = absl::StatusCode::kInvalidArgument) {
    expect_refused(good, edit, message, code);
  };
  fails_with([&](auto& c) { c[first].mutable_texture()->set_texture(2); },
             "texture.texture: 2 is out of range (the header declares 2 textures)");
  fails_with([&](auto& c) { c[first].mutable_texture()->set_crc32(1); },
             "texture.crc32: texture 'wood.png': checksum");
  fails_with([&](auto& c) { std::swap(c[first], c[first + 1]); },
             "texture.offset: texture 'wood.png': offset 1024 but 0 bytes arrived so far");
  fails_with([&](auto& c) { c.pop_back(); },
             "textures[1] 'glow.jpg': has 0 bytes but the header declares 4");
  fails_with([&](auto& c) { c[0].mutable_header()->mutable_textures(1)->set_bytes(3); },
             "texture 'glow.jpg': 4 bytes exceed the 3 the header declares");
  fails_with([&](auto& c) { c[0].mutable_header()->mutable_textures(0)->set_bytes(0); },
             "textures[0] 'wood.png'.bytes: is 0");
  fails_with(
      [&](auto& c) {
        c[0].mutable_header()->mutable_materials(0)->mutable_color_map()->set_texture(3);
      },
      "materials[0].color_map.texture: 3 names no texture (the scene has 2 textures");
  fails_with(
      [&](auto& c) {
        c[0].mutable_header()->mutable_materials(0)->mutable_color_map()->set_wrap_u(
            static_cast<v1::TextureRef::Wrap>(7));
      },
      "materials[0].color_map.wrap_u: 7 is not a wrap mode");
  fails_with(
      [&](auto& c) {
        c[0].mutable_header()->mutable_materials(3)->set_alpha_mode(
            static_cast<v1::Material::AlphaMode>(5));
      },
      "materials[3].alpha_mode: 5 is not an alpha mode");
  fails_with(
      [&](auto& c) {
        c[0].mutable_header()->mutable_materials(3)->mutable_opacity_map()->set_texture(9);
      },
      "materials[3].opacity_map.texture: 9 names no texture");
  fails_with(
      [&](auto& c) {
        c[0].mutable_header()->mutable_materials(1)->mutable_emission_map()->set_scale_v(
            std::nanf(""));
      },
      "materials[1].emission_map: has a transform number that is not finite");
  // A file larger than the limit, or too many of them, is refused from the header.
  fails_with(
      [&](auto& c) {
        c[0].mutable_header()->mutable_textures(0)->set_bytes(kMaxTextureFileBytes + 1);
      },
      "textures[0] 'wood.png'.bytes", absl::StatusCode::kResourceExhausted);
  fails_with(
      [&](auto& c) {
        for (size_t i = 0; i < kMaxTextures; ++i) c[0].mutable_header()->add_textures();
      },
      "exceed the limit of 4096", absl::StatusCode::kResourceExhausted);
}

// Found by the scene_chunks fuzz target: uploads whose grid assembles but is damaged, refused by
// validation (as Engine::load runs it). A grid of another NanoVDB major version was refused
// through NanoVDB's Version::c_str(), leaking the string it returns; a grid type past NanoVDB's
// table of names would have been read out of bounds; a child offset far outside the buffer was
// added to a node's address before it was checked, a pointer overflow. All are refused by name,
// and the asan preset checks that nothing leaks or overflows on the way.
TEST(SceneWire, DamagedUploadedGridsAreRefusedByValidation) {
  auto refused = [](auto&& damage) {
    Scene scene = with_grid_fog();
    auto bytes = std::make_shared<AlignedBytes>(scene.media[0].grid->size());
    std::memcpy(bytes->data(), scene.media[0].grid->data(), bytes->size());
    damage(reinterpret_cast<nanovdb::GridData*>(bytes->data()));
    scene.media[0].grid = bytes;
    absl::StatusOr<Scene> back = assemble(encode(scene, 4096));
    EXPECT_TRUE(back.ok()) << back.status();
    const absl::Status valid = back.ok() ? validate_scene(*back) : back.status();
    EXPECT_EQ(valid.code(), absl::StatusCode::kInvalidArgument);
    return std::string(valid.message());
  };
  EXPECT_THAT(refused([](nanovdb::GridData* grid) { grid->mVersion = nanovdb::Version(1, 2, 3); }),
              HasSubstr("media.fog.grid: was written by NanoVDB 1.2.3; this build reads version"));
  EXPECT_THAT(refused([](nanovdb::GridData* grid) {
                grid->mGridType = static_cast<nanovdb::GridType>(0x7fffffff);
              }),
              HasSubstr("media.fog.grid: is a grid of unknown type 2147483647"));
  EXPECT_THAT(refused([](nanovdb::GridData* data) {
                auto* upper = reinterpret_cast<nanovdb::NanoGrid<float>*>(data)
                                  ->tree()
                                  .getFirstNode<nanovdb::NanoUpper<float>>();
                upper->data()->mTable[upper->beginChild().pos()].child = 0x0aaaaaaaaaaaaaa0;
              }),
              HasSubstr("media.fog.grid: a lower node lies outside the grid's buffer"));
}

// UpdateGeometry's changes round-trip; malformed ones are refused naming the change and field,
// and an upload that carries a stored scene's placements is refused.
TEST(SceneWire, MeshChangesRoundTripAndBadOnesAreNamed) {
  Affine turned = rotation_y_deg(30);
  turned.m[2][3] = -4.25;
  const MeshChange change{"shapes[2] 'box'", turned, std::vector<Vec3f>{{1, 2, 3}, {4, 5, 6}},
                          std::nullopt};
  google::protobuf::RepeatedPtrField<v1::MeshUpdate> wire_changes;
  *wire_changes.Add() = encode_mesh_change(change);
  *wire_changes.Add() = encode_mesh_change(
      {"only normals", std::nullopt, std::nullopt, std::vector<Vec3f>{{0, 1, 0}}});
  absl::StatusOr<std::vector<MeshChange>> back = decode_mesh_changes(wire_changes, "meshes");
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->size(), 2u);
  EXPECT_EQ((*back)[0].mesh, change.mesh);
  ASSERT_TRUE((*back)[0].transform.has_value());
  EXPECT_EQ((*back)[0].transform->m, turned.m);
  ASSERT_TRUE((*back)[0].positions.has_value());
  EXPECT_EQ((*back)[0].positions->at(1).y, 5.0f);
  EXPECT_FALSE((*back)[0].normals.has_value());
  EXPECT_FALSE((*back)[1].transform || (*back)[1].positions);
  EXPECT_EQ((*back)[1].normals->size(), 1u);

  const std::pair<std::function<void(v1::MeshUpdate&)>, const char*> bad[] = {
      {[](v1::MeshUpdate& m) { m.clear_mesh(); }, "meshes[0].mesh: is missing"},
      {[](v1::MeshUpdate& m) { m.add_transform(1); }, "meshes[0].transform: has 13 numbers"},
      {[](v1::MeshUpdate& m) { m.set_transform(3, INFINITY); },
       "meshes[0].transform: number 3 is inf, not finite"},
      {[](v1::MeshUpdate& m) { m.add_positions(7); },
       "meshes[0].positions: has 7 numbers, not three per vertex"},
      {[](v1::MeshUpdate& m) { m.set_positions(5, NAN); },
       "meshes[0].positions[1]: (4, 5, nan) is not finite"},
  };
  for (const auto& [spoil, message] : bad) {
    google::protobuf::RepeatedPtrField<v1::MeshUpdate> spoiled;
    *spoiled.Add() = encode_mesh_change(change);
    spoil(spoiled[0]);
    const absl::StatusOr<std::vector<MeshChange>> refused = decode_mesh_changes(spoiled, "meshes");
    ASSERT_FALSE(refused.ok()) << message;
    EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(std::string(refused.status().message()), HasSubstr(message));
  }

  std::vector<v1::SceneChunk> chunks = encode(bundled("cornell-box"), 1024);
  *chunks[0].mutable_header()->add_placements() = encode_mesh_change(change);
  const absl::StatusOr<Scene> upload = assemble(chunks);
  ASSERT_FALSE(upload.ok());
  EXPECT_THAT(std::string(upload.status().message()), HasSubstr("placements: are a stored scene"));
}

}  // namespace
}  // namespace caustica::wire
