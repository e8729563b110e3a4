#pragma once

#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/model/surface_projection.h"
#include "gpatlas_core/common/types.h"

#include <Eigen/Core>

#include <random>
#include <limits>
#include <string>
#include <vector>

namespace gpatlas_core {

// Size and sampling of a chart (paper eqs. 14 and 15). Radii are in metres; variances in the
// model's reported (paper-equivalent) units.
struct ChartConfig {
  // rho = rho_gain / V[f(centre)] (eq. 14), clamped to [rho_min_m, rho_max_m]. The default
  // gives rho = 2 cm at the paper's V_max = 0.1.
  double rho_gain{0.002};
  double rho_min_m{0.005};
  double rho_max_m{0.04};
  // Candidates are drawn uniformly (in area) in the annulus [inner_fraction * rho, rho].
  double annulus_inner_fraction{0.8};
  // #candidates = round(candidate_density * rho / rho_max) (eq. 15), clamped to the bounds.
  double candidate_density{40.0};
  int min_candidates{6};
  int max_candidates{60};
};

// A direction in which a chart can still be expanded.
struct ChartCandidate {
  Eigen::Vector2d tangent{Eigen::Vector2d::Zero()};  // u, chart coordinates (metres)
  Vector3 ambient{Vector3::Zero()};                  // x_i + Phi_i u (eq. 12)
  double variance{0.0};  // V[f] at the ambient point, which is what eq. 16 ranks
};

// A local parametrisation of the predicted surface around a surface point (paper 3.2).
struct Chart {
  Vector3 centre{Vector3::Zero()};
  Vector3 normal{Vector3::UnitZ()};  // outward unit normal, grad f / |grad f|
  TangentBasis tangent_basis{TangentBasis::Zero()};
  double radius{0.0};  // rho, metres
  double variance{0.0};
  double slope{0.0};   // |grad f| at the centre, per metre (the position sd's denominator)
  double mean{0.0};    // f at the centre, |f| below the projection tolerance
  int parent{-1};      // index in the atlas, -1 for the root
  // The direction a touch of the centre comes from, when the planner's TouchFilter chose one
  // (it may be tilted from the normal); zero: along the normal.
  Vector3 approach_direction{Vector3::Zero()};
  // It needed a touch, and the planner's TouchFilter found no way to make it.
  bool out_of_reach{false};
  std::vector<ChartCandidate> candidates;

  bool expandable() const { return !candidates.empty(); }
  // Exponential-map approximation (eq. 12).
  Vector3 toAmbient(const Eigen::Vector2d& u) const { return centre + tangent_basis * u; }
  // Strictly inside the chart's validity ball.
  bool ballContains(const Vector3& x) const { return (x - centre).squaredNorm() < radius * radius; }
};

double chartRadius(double variance, const ChartConfig& config);
int candidateCount(double radius, const ChartConfig& config);

struct ChartCreation {
  bool ok{false};
  std::string message;
  Chart chart;
};

// Builds the chart at a projected surface point: tangent basis from the gradient, radius from
// the variance, candidates in the annulus with their variances from one batched query.
// Candidates whose ambient point lies outside the model's domain are not kept.
// `max_radius_m` caps the variance's radius (see SurfaceEvidence::radiusCap). Without
// `rank_candidates` the candidates' variances are not queried (left 0): an atlas grown over the
// whole surface expands every candidate anyway, and their ranking (eq. 16) only orders it.
ChartCreation createChart(const SurfaceModel& model, const SurfacePoint& centre, int parent,
                          const ChartConfig& config, std::mt19937_64& rng,
                          double max_radius_m = std::numeric_limits<double>::infinity(),
                          bool rank_candidates = true);
// The candidates' variances (eq. 16's ranking); those whose variance is not finite are dropped.
void rankCandidates(const SurfaceModel& model, std::vector<ChartCandidate>* candidates);

// Reports a problem with the configuration, or an empty string when it is usable.
std::string validate(const ChartConfig& config);

}  // namespace gpatlas_core
