// End to end over loopback: every field of caustica.v1.RenderSettings, found through the proto's
// descriptor so that a new field is covered without editing this test, changed by UpdateSettings
// on a scene that has rendered, for every integrator and estimator. The change either takes effect
// (the next frame is the frame of a fresh upload with the changed settings, bit for bit on the
// CPU) or is refused with a status that names the setting, as the fresh upload is, and the scene
// keeps rendering its old frame.
// The server runs on the device CAUSTICA_TEST_DEVICE names (the harness passes it on).
#include <google/protobuf/descriptor.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "proto/wire/scene_wire.h"
#include "renderer/render/image_error.h"
#include "renderer/scene/scene.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

constexpr int kWidth = 32, kHeight = 24;
constexpr uint32_t kPhotons = 3000, kK = 16, kSeed = 5, kPasses = 2;

// The settings a scene starts from: each integrator, and each estimator of the photon
// integrator, knn with and without final gathering.
struct Base {
  const char* name;
  Integrator integrator;
  EstimatorKind estimator;
  bool final_gather;
};
std::vector<Base> bases() {
  std::vector<Base> out;
  for (const SettingKind<EstimatorKind>& estimator : kEstimatorKinds)
    out.push_back({estimator.name, Integrator::kPhoton, estimator.value, false});
  out.push_back({"knn with final gathering", Integrator::kPhoton, EstimatorKind::kKnn, true});
  out.push_back({"path", Integrator::kPath, EstimatorKind::kKnn, false});
  return out;
}

Scene base_scene(const Base& base) {
  Scene scene = cornell_box(kWidth, kHeight, kPhotons, kK, kSeed);
  scene.settings.integrator = base.integrator;
  scene.settings.estimator = base.estimator;
  scene.settings.final_gather = base.final_gather;
  scene.settings.final_gather_rays = 16;
  scene.settings.final_gather_seeds = 64;
  return scene;
}

// The number the rules below put in place of an unsigned `now`: half, or one more for 0 and 1.
uint32_t other_uint32(uint32_t now) { return now >= 2 ? now / 2 : now + 1; }

// Values of `field` other than the one `current` holds, each set alone in a message of
// `current`'s type: every other value of an enum (0 would mean "unset"), half an integer (or one
// more where that is 0 or 1), half a float (0.5 for 0), the other boolean; each change of a
// message field's own fields; for a list of messages, the list with every number of every element
// changed so. A failure for a type this test cannot yet vary, so that a new kind of field is not
// silently left out.
std::vector<std::unique_ptr<Message>> changes_of(const FieldDescriptor& field,
                                                 const Message& current) {
  const google::protobuf::Reflection& get = *current.GetReflection();
  std::vector<std::unique_ptr<Message>> out;
  auto add = [&](auto set) {
    std::unique_ptr<Message> change(current.New());
    set(*change->GetReflection(), *change);
    out.push_back(std::move(change));
  };
  if (field.is_repeated()) {
    if (field.cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE ||
        get.FieldSize(current, &field) == 0) {
      ADD_FAILURE() << "no values to try for the list " << field.full_name()
                    << ": teach changes_of its type, or give it elements to vary";
      return out;
    }
    add([&](const auto& set, auto& message) {
      for (int i = 0; i < get.FieldSize(current, &field); ++i) {
        Message& element = *set.AddMessage(&message, &field);
        element.CopyFrom(get.GetRepeatedMessage(current, &field, i));
        const google::protobuf::Reflection& in = *element.GetReflection();
        for (int f = 0; f < element.GetDescriptor()->field_count(); ++f) {
          const FieldDescriptor& number = *element.GetDescriptor()->field(f);
          if (number.cpp_type() != FieldDescriptor::CPPTYPE_UINT32 || number.is_repeated()) {
            ADD_FAILURE() << "no values to try for " << number.full_name();
            continue;
          }
          in.SetUInt32(&element, &number, other_uint32(in.GetUInt32(element, &number)));
        }
      }
    });
    return out;
  }
  switch (field.cpp_type()) {
    case FieldDescriptor::CPPTYPE_MESSAGE: {
      const Message& now = get.GetMessage(current, &field);
      for (int f = 0; f < field.message_type()->field_count(); ++f) {
        for (const std::unique_ptr<Message>& inner :
             changes_of(*field.message_type()->field(f), now))
          add([&](const auto& set, auto& message) {
            set.MutableMessage(&message, &field)->CopyFrom(*inner);
          });
      }
      break;
    }
    case FieldDescriptor::CPPTYPE_ENUM: {
      const int now = get.GetEnumValue(current, &field);
      for (int i = 0; i < field.enum_type()->value_count(); ++i) {
        const int value = field.enum_type()->value(i)->number();
        if (value == 0 || value == now) continue;
        add([&](const auto& set, auto& message) { set.SetEnumValue(&message, &field, value); });
      }
      break;
    }
    case FieldDescriptor::CPPTYPE_UINT32: {
      const uint32_t value = other_uint32(get.GetUInt32(current, &field));
      add([&](const auto& set, auto& message) { set.SetUInt32(&message, &field, value); });
      break;
    }
    case FieldDescriptor::CPPTYPE_FLOAT: {
      const float now = get.GetFloat(current, &field);
      const float value = now > 0 ? now * 0.5f : 0.5f;
      add([&](const auto& set, auto& message) { set.SetFloat(&message, &field, value); });
      break;
    }
    case FieldDescriptor::CPPTYPE_BOOL: {
      const bool value = !get.GetBool(current, &field);
      add([&](const auto& set, auto& message) { set.SetBool(&message, &field, value); });
      break;
    }
    default:
      ADD_FAILURE() << "no values to try for " << field.full_name() << " of type "
                    << field.cpp_type_name() << ": teach changes_of its type";
  }
  return out;
}

// Whether a test server renders on the CPU, where renders are bit-for-bit repeatable.
bool on_cpu() {
  const char* device = std::getenv("CAUSTICA_TEST_DEVICE");
  return device == nullptr || *device == '\0' || std::string(device) == "cpu";
}

double relative_rmse(const std::vector<float>& reference, const std::vector<float>& image) {
  return image_error(image, reference, kWidth, kHeight).relative_rmse;
}

grpc::Status update_settings(v1::RenderService::Stub& stub, const std::string& id,
                             const v1::RenderSettings& settings) {
  v1::UpdateSettingsRequest request;
  request.set_scene_id(id);
  *request.mutable_settings() = settings;
  v1::RebuildReport report;
  grpc::ClientContext context;
  set_deadline(context);
  return stub.UpdateSettings(&context, request, &report);
}

TEST_F(ServerTest, EverySettingTakesEffectOrIsRefusedByName) {
  const google::protobuf::Descriptor& settings = *v1::RenderSettings::descriptor();
  ASSERT_GT(settings.field_count(), 0);
  int changes_made = 0, changes_refused = 0;
  for (const Base& base : bases()) {
    SCOPED_TRACE(base.name);
    const Scene scene = base_scene(base);
    const v1::RenderSettings current = wire::encode_settings(scene.settings);
    for (int f = 0; f < settings.field_count(); ++f) {
      const FieldDescriptor& field = *settings.field(f);
      for (const std::unique_ptr<Message>& changed_field : changes_of(field, current)) {
        const auto& change = static_cast<const v1::RenderSettings&>(*changed_field);
        SCOPED_TRACE(absl::StrCat("UpdateSettings{", change.ShortDebugString(), "}"));
        // The scene has rendered before the change, so that whatever lives across passes and
        // calls (maps, an estimator's state, a structure) exists to be kept or replaced.
        const std::string id = upload_scene(*stub_, scene, "changed");
        const std::vector<float> before = render_linear(*stub_, id, kPasses);
        const grpc::Status updated = update_settings(*stub_, id, change);

        // The same settings in a fresh upload.
        absl::StatusOr<RenderSettings> changed =
            wire::apply_settings(change, scene.settings, "settings");
        ASSERT_TRUE(changed.ok()) << changed.status();
        Scene fresh = scene;
        fresh.settings = *changed;
        v1::SceneInfo fresh_info;
        const grpc::Status uploaded = upload(*stub_, scene_chunks(fresh, "fresh"), &fresh_info);

        if (!updated.ok()) {
          ++changes_refused;
          EXPECT_FALSE(uploaded.ok())
              << "UpdateSettings refused what an upload accepts: " << updated.error_message();
          EXPECT_EQ(updated.error_code(), uploaded.error_code());
          EXPECT_NE(updated.error_message().find("settings."), std::string::npos)
              << "the refusal names no setting: " << updated.error_message();
          EXPECT_TRUE(render_linear(*stub_, id, kPasses) == before)
              << "a refused change changed the frame";
        } else {
          ++changes_made;
          ASSERT_TRUE(uploaded.ok())
              << "an upload refused what UpdateSettings accepted: " << uploaded.error_message();
          EXPECT_EQ(get_scene(*stub_, id).settings().ShortDebugString(),
                    fresh_info.settings().ShortDebugString());
          const std::vector<float> after = render_linear(*stub_, id, kPasses);
          const std::vector<float> expected = render_linear(*stub_, fresh_info.scene_id(), kPasses);
          ASSERT_EQ(after.size(), expected.size());
          if (on_cpu()) {
            EXPECT_TRUE(after == expected)
                << "the frame after the change is not the fresh upload's: relative RMS "
                << relative_rmse(expected, after);
          } else {
            EXPECT_LT(relative_rmse(expected, after), 0.01);
          }
          delete_scene(*stub_, fresh_info.scene_id());
        }
        delete_scene(*stub_, id);
      }
    }
  }
  // Both outcomes happen: final gathering is refused for sppm and vkde, everything else is taken.
  EXPECT_GT(changes_made, 0);
  EXPECT_GT(changes_refused, 0);
}

}  // namespace
}  // namespace caustica::testing
