// The --structure NAME option shared by the command-line tools (caustica, caustica-render,
// caustica-bench): a structure's name turned into the StructureKind the option stores, an unknown
// name refused with the list of known ones.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <optional>
#include <string>

#include "renderer/accel/structure_kind.h"

namespace caustica {

// A CLI11 transform: NAME to the number of its StructureKind, which CLI11 then stores in an
// (optional) StructureKind option.
inline CLI::Validator structure_names() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        const std::optional<StructureKind> kind = parse_structure_kind(value);
        if (!kind) return unknown_structure_message(value);
        value = std::to_string(static_cast<uint32_t>(*kind));
        return {};
      },
      "");
}

}  // namespace caustica
