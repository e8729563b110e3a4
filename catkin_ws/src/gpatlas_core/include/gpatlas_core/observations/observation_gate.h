#pragma once

#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/common/types.h"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// Which touch observations a model may take. One wrong contact far from the object moves the
// model's frame (renormalisation) and ruins every later plan, so observations are checked
// before they reach the model.
struct ObservationGateConfig {
  // The workspace, world frame: contacts and free space outside this box are refused. The
  // default is segmentation's crop box (ObjectSegmenter::Config).
  Vector3 workspace_min_m{0.2, -0.5, -0.05};
  Vector3 workspace_max_m{1.4, 0.5, 0.6};
  // A contact farther than this from every surface observation (the view's points and earlier
  // contacts) is refused when the model cannot explain it: it lies outside the model's domain,
  // or its mean f is more than max_inconsistency_sigma standard deviations from 0 (the model
  // is confident that no surface is there). Empty: no such test.
  std::optional<double> max_contact_distance_m{0.1};
  double max_inconsistency_sigma{4.0};
};

// Empty when the config is usable; otherwise what is wrong with it.
std::string validate(const ObservationGateConfig& config);

// Refused observations, by reason.
struct GateRefusals {
  std::size_t non_finite{0};
  std::size_t outside_workspace{0};
  std::size_t inconsistent{0};  // contacts only
  std::size_t total() const { return non_finite + outside_workspace + inconsistent; }
};

struct GatedObservations {
  std::vector<Contact> contacts;
  std::vector<Vector3> free_space;
  GateRefusals contacts_refused;
  GateRefusals free_space_refused;
  std::size_t refused() const { return contacts_refused.total() + free_space_refused.total(); }
  // "refused 1 contact (1 inconsistent with the model: 0.45 m from every surface observation,
  // outside the model's domain)", or empty when nothing was refused.
  std::string message;
};

// The observations that pass: finite, inside the workspace, and (contacts) near the data or
// explained by the model. Needs a fitted model for the consistency test; without one only the
// first two apply. A contact's non-finite normal is not a reason to refuse it: it becomes
// unknown (zero).
GatedObservations gateObservations(const SurfaceModel& model, const std::vector<Contact>& contacts,
                                   const std::vector<Vector3>& free_space, const ObservationGateConfig& config);

}  // namespace gpatlas_core
