#pragma once

// oracle_poke: an analysis tool of the bench, not a strategy for a robot. It cheats: it reads the
// truth. At every plan it takes atlas_poke's candidates (the charts its best_score selection
// scores, its own choice first) and the first max_variance_candidates points max_variance would
// poke, probes each against the true scene with a prober of its own, adds what the probe found to
// a copy of the model as the loop's update would (applyTouch), and pokes the candidate whose copy
// scores best against the truth (F@5mm in the bench; ties: the first). A greedy one-step bound on
// what a better choice among those candidates could reach with the same probe and model. It
// stops where atlas_poke's plan stops (converged, capped), so that the choice is all that differs.

#include <gpatlas_core/exploration/prober.h>
#include <gpatlas_core/planning/exploration_strategy.h>
#include <gpatlas_core/planning/baseline_strategies.h>
#include <gpatlas_core/planning/strategy_registry.h>

#include <cmath>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gpatlas_bench {

inline constexpr char kOracleStrategy[] = "oracle_poke";

struct OracleCandidate {
  gpatlas_core::Touch touch;  // a poke, along the direction the approacher's cheap test chose
  // "atlas_poke" (its choice), "scored" (another chart its selection scored) or "max_variance N"
  // (the N-th point max_variance would poke, 1: its choice).
  std::string source;
  double score{std::nan("")};  // the model's score after the touch
};

// One plan of the oracle: the model's score before it, every candidate and the one chosen.
struct OraclePlan {
  double score_before{std::nan("")};
  std::vector<OracleCandidate> candidates;
  std::size_t best{0};
  double seconds{0.0};
};

// "SOURCE at (x, y, z) m along (nx, ny, nz)": the candidate's touch.
std::string describe(const OracleCandidate& candidate);

class OracleStrategy : public gpatlas_core::ExplorationStrategy {
 public:
  // How a model scores against the truth (higher is better; NaN: no surface, worst).
  using Score = std::function<double(const gpatlas_core::SurfaceModel& model)>;
  // A touch probed against the truth, by a prober that is not the loop's.
  using Probe = std::function<gpatlas_core::ProbeResult(const gpatlas_core::Touch& touch)>;
  using Report = std::function<void(const OraclePlan& plan)>;
  struct Config {
    int max_variance_candidates{8};
  };

  // atlas_poke and max_variance read their settings from `settings` (makeStrategy); `seed` is
  // the run's.
  OracleStrategy(Config config, gpatlas_core::ParamReader& settings, std::uint64_t seed, Probe probe, Score score,
                 Report report = {});
  std::string name() const override { return kOracleStrategy; }
  gpatlas_core::PlanResult plan(const gpatlas_core::SurfaceModel& model,
                                const gpatlas_core::PlanRequest& request) const override;

  // The candidates of a plan on `model` whose atlas_poke plan was `atlas_plan` (a touch), unscored.
  std::vector<OracleCandidate> candidates(const gpatlas_core::SurfaceModel& model,
                                          const gpatlas_core::PlanRequest& request,
                                          const gpatlas_core::PlanResult& atlas_plan) const;
  // The model's score after `touch` (the model's own when the probe found nothing or the model
  // refused it): the loop's update on a copy.
  double scoreAfter(const gpatlas_core::SurfaceModel& model, const gpatlas_core::Touch& touch,
                    const gpatlas_core::TouchObservationConfig& observations, double score_before) const;

 private:
  Config config_;
  std::unique_ptr<gpatlas_core::ExplorationStrategy> atlas_poke_;
  gpatlas_core::MaxVarianceStrategy max_variance_;
  Probe probe_;
  Score score_;
  Report report_;
};

}  // namespace gpatlas_bench
