#include "gpatlas_core/planning/chart.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace gpatlas_core {

std::string validate(const ChartConfig& config) {
  std::ostringstream problem;
  if (!(config.rho_min_m > 0.0) || !(config.rho_max_m >= config.rho_min_m) || !std::isfinite(config.rho_max_m))
    problem << "chart radius bounds must satisfy 0 < rho_min_m <= rho_max_m < inf; ";
  if (!(config.rho_gain > 0.0) || !std::isfinite(config.rho_gain)) problem << "rho_gain must be positive; ";
  if (!(config.annulus_inner_fraction >= 0.0 && config.annulus_inner_fraction < 1.0))
    problem << "annulus_inner_fraction must be in [0, 1); ";
  if (!(config.candidate_density > 0.0) || !std::isfinite(config.candidate_density))
    problem << "candidate_density must be positive; ";
  if (config.min_candidates < 1 || config.max_candidates < config.min_candidates)
    problem << "candidate bounds must satisfy 1 <= min_candidates <= max_candidates; ";
  return problem.str();
}

double chartRadius(double variance, const ChartConfig& config) {
  // A zero variance (exact data, no noise) would give an infinite chart: the upper clamp is
  // what keeps charts local where the model is certain.
  if (!(variance > 0.0)) return config.rho_max_m;
  return std::clamp(config.rho_gain / variance, config.rho_min_m, config.rho_max_m);
}

int candidateCount(double radius, const ChartConfig& config) {
  const double count = std::round(config.candidate_density * radius / config.rho_max_m);
  return static_cast<int>(std::clamp(count, static_cast<double>(config.min_candidates),
                                     static_cast<double>(config.max_candidates)));
}

ChartCreation createChart(const SurfaceModel& model, const SurfacePoint& centre, int parent,
                          const ChartConfig& config, std::mt19937_64& rng, double max_radius_m,
                          bool rank_candidates) {
  ChartCreation creation;
  if (!centre.ok || !centre.position.allFinite() || !centre.gradient.allFinite() ||
      !std::isfinite(centre.variance)) {
    creation.message = "chart centre is not a valid surface point";
    return creation;
  }
  const double gradient_norm = centre.gradient.norm();
  if (!(gradient_norm > 0.0)) {
    creation.message = "zero gradient at the chart centre: no tangent plane";
    return creation;
  }
  Chart& chart = creation.chart;
  chart.centre = centre.position;
  chart.normal = centre.gradient / gradient_norm;
  chart.tangent_basis = tangentBasis(chart.normal);
  chart.variance = centre.variance;
  chart.slope = gradient_norm;
  chart.mean = centre.mean;
  chart.parent = parent;
  chart.radius = std::min(chartRadius(centre.variance, config), max_radius_m);

  const int count = candidateCount(chart.radius, config);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double inner_squared = config.annulus_inner_fraction * config.annulus_inner_fraction;
  std::vector<ChartCandidate> candidates;
  candidates.reserve(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k) {
    // Radius distributed as sqrt of a uniform on [inner^2, 1]: uniform density per unit area.
    const double r = chart.radius * std::sqrt(inner_squared + (1.0 - inner_squared) * unit(rng));
    const double angle = 2.0 * M_PI * unit(rng);
    ChartCandidate candidate;
    candidate.tangent = Eigen::Vector2d(r * std::cos(angle), r * std::sin(angle));
    candidate.ambient = chart.toAmbient(candidate.tangent);
    if (model.inDomain(candidate.ambient)) candidates.push_back(candidate);
  }
  if (rank_candidates) rankCandidates(model, &candidates);
  chart.candidates = std::move(candidates);
  creation.ok = true;
  return creation;
}

void rankCandidates(const SurfaceModel& model, std::vector<ChartCandidate>* candidates) {
  if (candidates->empty()) return;
  Points3 ambient(3, static_cast<Eigen::Index>(candidates->size()));
  for (std::size_t k = 0; k < candidates->size(); ++k) ambient.col(static_cast<Eigen::Index>(k)) = (*candidates)[k].ambient;
  const BatchPrediction prediction = model.predictBatch(ambient, /*with_gradient=*/false,
                                                        /*with_variance_gradient=*/false);
  for (std::size_t k = 0; k < candidates->size(); ++k) {
    const double variance = prediction.variance(static_cast<Eigen::Index>(k));
    // A NaN variance would poison the arg-max of eq. 16; such a direction is unusable.
    (*candidates)[k].variance = std::isfinite(variance) ? variance : -1.0;
  }
  candidates->erase(std::remove_if(candidates->begin(), candidates->end(),
                                   [](const ChartCandidate& c) { return c.variance < 0.0; }),
                    candidates->end());
}

}  // namespace gpatlas_core
