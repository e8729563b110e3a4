#pragma once

// A strategy made as the tools make it: by name (makeStrategy), reading its settings from
// "key=value" assignments (YAML values, config/pipeline.yaml's names) over the code's defaults.

#include "gpatlas_core/common/parameters.h"
#include "gpatlas_core/planning/strategy_registry.h"

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace gpatlas_core::testing {

// Throws std::invalid_argument when an assignment is malformed or the strategy refuses a value.
inline std::unique_ptr<ExplorationStrategy> strategyWith(const std::string& name,
                                                         const std::vector<std::string>& settings,
                                                         std::uint64_t seed = 0) {
  std::string error;
  const std::unique_ptr<YamlParameters> params = YamlParameters::fromString("{}", &error);
  for (const std::string& assignment : settings)
    if (!params->set(assignment, &error)) throw std::invalid_argument(error);
  ParamReader reader(*params);
  std::unique_ptr<ExplorationStrategy> strategy = makeStrategy(name, reader, seed);
  if (!reader.ok()) throw std::invalid_argument(name + ": " + reader.errors());
  return strategy;
}

}  // namespace gpatlas_core::testing
