// The options that name a setting (--integrator NAME, --estimator NAME) shared by the command-line
// tools (caustica, caustica-render): a name turned into the number of its enum value, which CLI11
// then stores in an (optional) enum option; anything else refused with every name.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "renderer/photon/estimator_kind.h"
#include "renderer/scene/scene.h"

namespace caustica {

// A CLI11 transform from the names of `values` (name, enum value) to their numbers; `what` names
// the setting in the refusal.
template <typename Enum>
CLI::Validator setting_names(const std::string& what,
                             std::initializer_list<std::pair<const char*, Enum>> values) {
  const std::vector<std::pair<std::string, Enum>> table(values.begin(), values.end());
  std::string expected;
  for (size_t i = 0; i < table.size(); ++i)
    expected += (i == 0 ? "" : i + 1 == table.size() ? " or " : ", ") + table[i].first;
  return CLI::Validator(
      [=](std::string& value) -> std::string {
        for (const auto& [name, v] : table) {
          if (value == name) {
            value = std::to_string(static_cast<uint32_t>(v));
            return {};
          }
        }
        return "unknown " + what + " '" + value + "' (expected " + expected + ")";
      },
      "");
}

inline CLI::Validator integrator_names() {
  return setting_names<Integrator>("integrator",
                                   {{"photon", Integrator::kPhoton}, {"path", Integrator::kPath}});
}

inline CLI::Validator estimator_names() {
  return setting_names<EstimatorKind>("estimator", {{"knn", EstimatorKind::kKnn},
                                                    {"sppm", EstimatorKind::kSppm},
                                                    {"vkde", EstimatorKind::kVkde}});
}

}  // namespace caustica
