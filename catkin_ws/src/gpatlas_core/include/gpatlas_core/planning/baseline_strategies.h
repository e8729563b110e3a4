#pragma once

#include "gpatlas_core/planning/exploration_strategy.h"
#include "gpatlas_core/planning/surface_sampler.h"
#include "gpatlas_core/observations/surface_evidence.h"
#include "gpatlas_core/planning/stop_rule.h"

namespace gpatlas_core {

// Both baselines sample the predicted surface (SurfaceSampler) and share one stopping rule:
// converged when no sampled surface point is past the StopRule (or, with an evidence
// distance in their rule, lies that far from every measured surface point). This is a sample-based
// certificate, weaker than the atlas's coverage argument, and is documented as such. Each pokes
// the first of its choices that PlanRequest::reachable accepts (of the first 32 it tries), as
// a robot would: a baseline that pokes where the probe cannot go measures the approacher.

// The paper's Random Poke: a uniformly random point among the sampled surface points,
// whatever its variance.
class RandomStrategy : public ExplorationStrategy {
 public:
  RandomStrategy(SurfaceSampler::Config config, EvidenceRule evidence, std::uint64_t seed);
  std::string name() const override { return "random"; }
  PlanResult plan(const SurfaceModel& model, const PlanRequest& request) const override;

 private:
  SurfaceSampler::Config config_;
  EvidenceRule evidence_;
  std::uint64_t seed_;
};

// The usual GPIS baseline: the point of a dense surface sample furthest past the stop rule
// (StopRule::excess: the highest variance under V_max alone; with a position sd bound, the
// larger of variance / V_max and position sd / bound), or once none is past it, a point without
// evidence.
class MaxVarianceStrategy : public ExplorationStrategy {
 public:
  MaxVarianceStrategy(SurfaceSampler::Config config, EvidenceRule evidence, std::uint64_t seed);
  std::string name() const override { return "max_variance"; }
  PlanResult plan(const SurfaceModel& model, const PlanRequest& request) const override;
  // The pokes plan() would choose among, in its order: of the first 32 ranked points, the first
  // `count` that PlanRequest::reachable accepts, along the direction it chose (along the normal
  // without a test). Empty when plan() would not touch (converged or an error).
  std::vector<Touch> rankedPokes(const SurfaceModel& model, const PlanRequest& request, int count) const;

 private:
  SurfaceSampler::Config config_;
  EvidenceRule evidence_;
  std::uint64_t seed_;
};

}  // namespace gpatlas_core
