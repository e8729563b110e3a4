#include "gpatlas_core/observations/observation_gate.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <iomanip>
#include <sstream>

namespace gpatlas_core {

namespace {

bool inWorkspace(const ObservationGateConfig& c, const Vector3& x) {
  return (x.array() >= c.workspace_min_m.array()).all() && (x.array() <= c.workspace_max_m.array()).all();
}

std::string plural(std::size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

}  // namespace

std::string validate(const ObservationGateConfig& c) {
  std::ostringstream problem;
  if (c.workspace_min_m.array().isNaN().any() || c.workspace_max_m.array().isNaN().any() ||
      !(c.workspace_min_m.array() <= c.workspace_max_m.array()).all())
    problem << "workspace_min_m must be <= workspace_max_m on every axis; ";
  if (c.max_contact_distance_m && (!(*c.max_contact_distance_m > 0.0) || !std::isfinite(*c.max_contact_distance_m)))
    problem << "max_contact_distance_m must be finite and > 0, or empty (no consistency test); ";
  if (!(c.max_inconsistency_sigma > 0.0) || !std::isfinite(c.max_inconsistency_sigma))
    problem << "max_inconsistency_sigma must be finite and > 0; ";
  return problem.str();
}

GatedObservations gateObservations(const SurfaceModel& model, const std::vector<Contact>& contacts,
                                   const std::vector<Vector3>& free_space, const ObservationGateConfig& config) {
  GatedObservations out;
  const bool consistency = config.max_contact_distance_m && model.isFitted();
  const double unit = consistency ? model.varianceUnitFactor() : 1.0;
  // The worst refused contact, for the message.
  double worst_distance = -1.0;
  bool worst_outside_domain = false;
  double worst_sigmas = 0.0;
  for (Contact c : contacts) {
    if (!c.position.allFinite()) {
      ++out.contacts_refused.non_finite;
      continue;
    }
    if (!c.normal.allFinite()) c.normal = Vector3::Zero();
    if (!inWorkspace(config, c.position)) {
      ++out.contacts_refused.outside_workspace;
      continue;
    }
    if (consistency) {
      const double distance = model.nearestSurfaceDistance(c.position);
      if (distance > *config.max_contact_distance_m) {
        const bool outside_domain = !model.inDomain(c.position);
        double sigmas = 0.0;
        if (!outside_domain) {
          const Prediction p = model.predict(c.position);
          const double sd = std::sqrt(std::max(0.0, p.variance / unit));
          sigmas = sd > 0.0 ? std::abs(p.mean) / sd : std::numeric_limits<double>::infinity();
        }
        if (outside_domain || sigmas > config.max_inconsistency_sigma) {
          ++out.contacts_refused.inconsistent;
          if (distance > worst_distance) {
            worst_distance = distance;
            worst_outside_domain = outside_domain;
            worst_sigmas = sigmas;
          }
          continue;
        }
      }
    }
    out.contacts.push_back(c);
  }
  for (const Vector3& x : free_space) {
    if (!x.allFinite()) {
      ++out.free_space_refused.non_finite;
    } else if (!inWorkspace(config, x)) {
      ++out.free_space_refused.outside_workspace;
    } else {
      out.free_space.push_back(x);
    }
  }

  if (out.refused() == 0) return out;
  std::ostringstream m;
  m << std::setprecision(3) << "refused ";
  bool first = true;
  const auto part = [&](const GateRefusals& r, const char* one, const char* many) {
    if (r.total() == 0) return;
    if (!first) m << " and ";
    first = false;
    m << plural(r.total(), one, many) << " (";
    bool inner_first = true;
    const auto reason = [&](std::size_t n, const std::string& why) {
      if (n == 0) return;
      m << (inner_first ? "" : ", ") << n << " " << why;
      inner_first = false;
    };
    reason(r.non_finite, "not finite");
    reason(r.outside_workspace, "outside the workspace box");
    if (r.inconsistent > 0) {
      std::ostringstream why;
      why << std::setprecision(3) << "inconsistent with the model: up to " << worst_distance
          << " m from every surface observation, ";
      if (worst_outside_domain) why << "outside the model's domain";
      else why << "f " << worst_sigmas << " standard deviations from 0";
      reason(r.inconsistent, why.str());
    }
    m << ")";
  };
  part(out.contacts_refused, "contact", "contacts");
  part(out.free_space_refused, "free-space point", "free-space points");
  out.message = m.str();
  return out;
}

}  // namespace gpatlas_core
