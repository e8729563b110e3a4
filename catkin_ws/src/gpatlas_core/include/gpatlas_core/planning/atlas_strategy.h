#pragma once

#include "gpatlas_core/planning/atlas_planner.h"
#include "gpatlas_core/planning/exploration_strategy.h"

namespace gpatlas_core {

// GPAtlasRRT as a strategy. Poke touches the last chart of the path (the uncertain one);
// slide follows the whole path from the root, as in the paper's sliding condition.
class AtlasStrategy : public ExplorationStrategy {
 public:
  enum class Mode { kPoke, kSlide };
  AtlasStrategy(Mode mode, AtlasPlanner::Config config, std::uint64_t seed);
  std::string name() const override;
  PlanResult plan(const SurfaceModel& model, const PlanRequest& request) const override;

 private:
  Mode mode_;
  AtlasPlanner::Config config_;
  std::uint64_t seed_;
};

}  // namespace gpatlas_core
