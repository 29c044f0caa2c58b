// The --structure NAME and --structure-option NAME=VALUE options shared by the command-line tools
// (caustica, caustica-render, caustica-bench): a structure's name turned into the StructureKind
// the option stores, an unknown name refused with the list of known ones, and a builder option
// checked as it is parsed.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <optional>
#include <string>

#include "renderer/accel/build_options.h"
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

inline constexpr const char* kStructureOptionHelp =
    "what the structure's builder is told, repeatable: binned-sah-stages=ABOVE:BINS,... "
    "(binned-sah and hybrid), binned-sah-reorder=sort|split, kd-traversal=stack|stackless, "
    "refit=auto|always|never and refit-sah-bound=B (what a geometry change does to lbvh4, "
    "binned-sah and hybrid)";

// A CLI11 check of one --structure-option, which the option keeps as written.
inline CLI::Validator structure_option_check() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        BuildOptions scratch;
        return apply_structure_option(value, scratch).value_or(std::string());
      },
      "NAME=VALUE");
}

}  // namespace caustica
