#pragma once

#include "gpatlas_core/planning/atlas_planner.h"
#include "gpatlas_core/planning/exploration_strategy.h"

#include <memory>
#include <mutex>

namespace gpatlas_core {

// GPAtlasRRT as a strategy. Poke touches the last chart of the path (the uncertain one);
// slide follows the whole path from the root, as in the paper's sliding condition. It keeps each
// plan's atlas for the next (AtlasMemory): the charts far from the model's new data are reused.
// Plans on another model (or the same after a refit) start afresh.
class AtlasStrategy : public ExplorationStrategy {
 public:
  enum class Mode { kPoke, kSlide };
  // `config` with the mode's rules: a slide selects the first chart that needs a touch
  // (Algorithm 1's path), a poke plans with extend_path_charts = 0.
  AtlasStrategy(Mode mode, AtlasPlanner::Config config, std::uint64_t seed);
  std::string name() const override;
  PlanResult plan(const SurfaceModel& model, const PlanRequest& request) const override;

 private:
  Mode mode_;
  AtlasPlanner::Config config_;
  std::uint64_t seed_;
  // The previous plan's atlas: plans are const (a strategy is shared), the memory is what they
  // leave behind, one plan at a time.
  struct Memory {
    std::mutex mutex;
    AtlasMemory atlas;
  };
  std::shared_ptr<Memory> memory_{std::make_shared<Memory>()};
};

}  // namespace gpatlas_core
