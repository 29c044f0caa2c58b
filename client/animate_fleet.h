// animate --servers A,B,C: the keyframes of one light script spread over several replicas.
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>
#include <vector>

#include "absl/status/status.h"
#include "client/commands.h"

namespace caustica::client {

// Uploads the scene file to every replica, renders each keyframe on whichever replica is free
// (one PlayAnimation of that keyframe alone, which starts from a cleared film, so the frame is the
// one a single server renders for it), hands the keyframe of a failed replica to another one and
// writes DIR/frame_NNNN.<format> in keyframe order. `after_frames` runs once every frame is
// written (the video); then the report, with each replica's frames and rate.
absl::Status run_animate_fleet(const GlobalOptions& global, const AnimateOptions& options,
                               std::vector<v1::Keyframe> keyframes,
                               const std::function<absl::Status()>& after_frames,
                               std::ostream& out);

}  // namespace caustica::client
