// The --integrator NAME option shared by the command-line tools (caustica, caustica-render):
// "photon" or "path" turned into the Integrator the option stores, anything else refused with
// both names.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "renderer/scene/scene.h"

namespace caustica {

// A CLI11 transform: NAME to the number of its Integrator, which CLI11 then stores in an
// (optional) Integrator option.
inline CLI::Validator integrator_names() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        if (value == "photon") {
          value = std::to_string(static_cast<uint32_t>(Integrator::kPhoton));
        } else if (value == "path") {
          value = std::to_string(static_cast<uint32_t>(Integrator::kPath));
        } else {
          return "unknown integrator '" + value + "' (expected photon or path)";
        }
        return {};
      },
      "");
}

}  // namespace caustica
