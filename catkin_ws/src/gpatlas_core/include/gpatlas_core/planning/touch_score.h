#pragma once

// Which touch removes the most error? Before touching, each candidate's observations are added
// to the model in fantasy (SurfaceModel::varianceAfter: a low-rank update, no refit) and the
// score is how much the surface's expected error beyond the stop rule's bound falls, summed
// over the surface with each point's area: a one-step lookahead of integrated uncertainty
// (Cohn's active learning by integrated variance, TruVaR's truncated variance), which favours
// the touch that informs most of the surface over the single most uncertain point.

#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/observations/touch_training.h"
#include "gpatlas_core/common/types.h"
#include "gpatlas_core/planning/stop_rule.h"

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

struct TouchScoreConfig {
  // The surface the score sums over: at most this many of the points past the stop rule's bound
  // (a random sample when there are more, each standing for its share of their area). Points
  // within the bound count for nothing, so they are left out.
  int max_reference_points{192};
  // Candidates scored per plan; when more need a touch, those furthest past the stop rule
  // (max_excess_candidates of them) and a random sample of the others.
  int max_candidates{32};
  int max_excess_candidates{8};
};

std::string validate(const TouchScoreConfig& config);

// How much error one surface point carries beyond the rule, per unit of area. With a bound b on
// the position sd: the probability that the true surface lies farther than b from the predicted
// one, 2 Phi(-b / sd), less its value at sd = b, so that a point within the bound counts for
// nothing and one far past it for at most about 0.68 (the area outside the tolerance of an
// F-score at b). Under V_max alone: the variance's excess, (v - V_max) / V_max, when positive.
double surfaceError(const SurfaceModel& model, const StopRule& rule, double reported_variance, double gradient_norm);

// The surface as weighted points: where, its area (m^2), and the model's variance and gradient
// norm there.
struct SurfacePatch {
  Vector3 point{Vector3::Zero()};
  double area_m2{0.0};
  double variance{0.0};
  double slope{0.0};
};

// A candidate touch: where it would touch, along which outward normal, and how far out along it
// the probe starts (0: the contact alone). The probe's way in is free space, and it is what
// carves a wrong prediction away, so the fantasy holds it as the loop would (approachFreeSpace).
struct TouchCandidate {
  Vector3 point{Vector3::Zero()};
  Vector3 normal{Vector3::UnitZ()};
  double approach_m{0.0};
};

// The free space a poke passes through on its way in: points along the normal from the contact
// out to `approach_m`, every `spacing_m` (none at the contact itself, where the probe stops).
std::vector<Vector3> approachFreeSpace(const TouchCandidate& candidate, double spacing_m);

struct TouchScores {
  bool ok{false};
  std::string message;
  // Per candidate: the fall of the summed error (m^2 of expected area outside the bound, or
  // the variance excess times area under V_max alone).
  std::vector<double> reduction;
  // The summed error before any touch, over the whole surface.
  double total_error{0.0};
};

// Scores every candidate against the surface `patches` (a sample of them, see the config). The
// candidate's fantasy observations are those a poke there would add (touchTrainingPoints of one
// contact with the candidate's normal and its approach's free space, under `touch`).
TouchScores scoreTouches(const SurfaceModel& model, const StopRule& rule, const std::vector<SurfacePatch>& patches,
                         const std::vector<TouchCandidate>& candidates, const TouchObservationConfig& touch,
                         const TouchScoreConfig& config, std::uint64_t seed);

}  // namespace gpatlas_core
