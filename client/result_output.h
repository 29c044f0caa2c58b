// How command results look: lines for people (aligned "label  value" rows, as caustica-render
// prints them) and, with --json, one JSON object per command on stdout for scripts. JSON follows
// the proto3 JSON mapping with the .proto field names (64-bit integers are strings there).
#pragma once

#include <google/protobuf/message.h>

#include <nlohmann/json.hpp>
#include <ostream>
#include <string>

#include "caustica/v1/render_service.pb.h"

namespace caustica::client {

nlohmann::json to_json(const google::protobuf::Message& message);
// A frame's header fields; the pixel bytes are left out.
nlohmann::json frame_header_json(const v1::Frame& frame);
// One line on `out`.
void print_json(std::ostream& out, const nlohmann::json& value);

std::string timings_text(const v1::StageTimings& timings);  // "structure 1.2 | ... ms"
std::string epochs_text(const v1::Epochs& epochs);          // "geometry 1, lights 2, ..."
std::string frame_text(const v1::Frame& frame);             // "64x64, 2 passes, lights epoch 3"
std::string mib_text(uint64_t bytes);                       // "1.25 MiB"
// "lbvh4, 1234 nodes, 0.12 MiB, SAH 45.6, built in 2.3 ms"
std::string structure_text(const v1::SceneInfo& info);

void print_rebuild_report(std::ostream& out, const v1::RebuildReport& report);
void print_scene_info(std::ostream& out, const v1::SceneInfo& info);
void print_scene_table(std::ostream& out,
                       const google::protobuf::RepeatedPtrField<v1::SceneInfo>& scenes);
void print_stats(std::ostream& out, const v1::Stats& stats);

}  // namespace caustica::client
