// The options that name a setting (--integrator NAME, --estimator NAME) shared by the command-line
// tools (caustica, caustica-render, caustica-bench): a name of the setting's table
// (scene/setting_kinds.h) turned into the number of its enum value, which CLI11 then stores in an
// (optional) enum option; anything else refused with every name.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <optional>
#include <string>

#include "renderer/scene/setting_kinds.h"

namespace caustica {

template <typename Enum>
CLI::Validator kind_names_validator() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        const std::optional<Enum> kind = parse_kind<Enum>(value);
        if (!kind) return unknown_kind_message<Enum>(value);
        value = std::to_string(static_cast<uint32_t>(*kind));
        return {};
      },
      "");
}

inline CLI::Validator integrator_names() { return kind_names_validator<Integrator>(); }
inline CLI::Validator estimator_names() { return kind_names_validator<EstimatorKind>(); }

}  // namespace caustica
