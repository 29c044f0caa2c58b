// The engine's reports and state as caustica.v1 messages: epochs, stage timings, rebuild reports
// and the parts of SceneInfo that change as a resident scene is updated and rendered.
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"
#include "renderer/engine.h"

namespace caustica::server {

v1::Epochs encode_epochs(const Epochs& epochs);
// Adds `timings` to `out` (frames and reports sum the stages of several engine calls).
void add_timings(const StageTimings& timings, v1::StageTimings* out);
void add_timings(const v1::StageTimings& timings, v1::StageTimings* out);
v1::RebuildReport encode_rebuild(const RebuildReport& report);

// The SceneInfo fields fixed at upload: name, counts of meshes, materials, vertices, emissive
// triangles, the meshes' names.
void describe_geometry(const Scene& scene, v1::SceneInfo* info);
// The fields that change with updates and passes, from the engine (call under the device lease).
void describe_state(const Engine& engine, v1::SceneInfo* info);
// The lights and the emissive materials' emission, which change only with updates.
void describe_lights(const Scene& scene, v1::SceneInfo* info);

// The change an UpdateLightsRequest asks for: the lights (none with keep_lights), the emitters and
// the environment.
absl::StatusOr<SceneChange> decode_change(const v1::UpdateLightsRequest& request);
// A keyframe's change, those and its meshes, with fields named under `prefix` ("keyframes[3].").
absl::StatusOr<SceneChange> decode_change(const v1::Keyframe& keyframe, const std::string& prefix);

}  // namespace caustica::server
