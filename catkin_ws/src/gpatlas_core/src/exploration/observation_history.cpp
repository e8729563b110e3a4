#include "gpatlas_core/exploration/observation_history.h"

#include "gpatlas_core/model/position_uncertainty.h"

#include <algorithm>
#include <memory>
#include <utility>

namespace gpatlas_core {

std::uint32_t ObservationHistory::setView(std::vector<TrainingPoint> view_training) {
  batches_.erase(std::remove_if(batches_.begin(), batches_.end(),
                                [](const ObservationBatch& b) { return b.kind == ObservationBatch::Kind::kView; }),
                 batches_.end());
  ObservationBatch view;
  view.id = next_id_++;
  view.kind = ObservationBatch::Kind::kView;
  view.view_training = std::move(view_training);
  batches_.insert(batches_.begin(), std::move(view));
  return batches_.front().id;
}

std::uint32_t ObservationHistory::addTouch(std::vector<Contact> contacts, std::vector<Vector3> free_space) {
  ObservationBatch touch;
  touch.id = next_id_++;
  touch.kind = ObservationBatch::Kind::kTouch;
  touch.contacts = std::move(contacts);
  touch.free_space = std::move(free_space);
  batches_.push_back(std::move(touch));
  return batches_.back().id;
}

void ObservationHistory::clear() { batches_.clear(); }

std::vector<ObservationBatch>::const_iterator ObservationHistory::find(std::uint32_t id) const {
  return std::find_if(batches_.begin(), batches_.end(), [id](const ObservationBatch& b) { return b.id == id; });
}

bool ObservationHistory::contains(std::uint32_t id) const { return find(id) != batches_.end(); }

std::size_t ObservationHistory::touchCount() const {
  return static_cast<std::size_t>(std::count_if(
      batches_.begin(), batches_.end(), [](const ObservationBatch& b) { return b.kind == ObservationBatch::Kind::kTouch; }));
}

std::vector<std::uint32_t> ObservationHistory::lastTouches(std::size_t n) const {
  std::vector<std::uint32_t> ids;
  for (auto it = batches_.rbegin(); it != batches_.rend() && ids.size() < n; ++it)
    if (it->kind == ObservationBatch::Kind::kTouch) ids.push_back(it->id);
  std::reverse(ids.begin(), ids.end());
  return ids;
}

namespace {

FitReport rebuildFrom(const std::vector<ObservationBatch>& batches, const TouchObservationConfig& touch,
                      SurfaceModel& model, const RebuildProgress& progress) {
  FitReport report;
  const auto view = std::find_if(batches.begin(), batches.end(),
                                 [](const ObservationBatch& b) { return b.kind == ObservationBatch::Kind::kView; });
  if (view == batches.end()) {
    report.message = "no view to build the model from";
    return report;
  }
  report = model.fit(view->view_training);
  if (!report.ok) return report;
  // The kept touches calibrate the scale again, in order; the view's folds stay.
  PositionSdEvidence evidence = model.positionSdEvidence();
  evidence.touches.clear();
  if (!evidence.view_folds.empty()) model.setPositionSdScale(positionSdScale(evidence));
  model.setPositionSdEvidence(std::move(evidence));
  const auto total = static_cast<std::size_t>(std::count_if(
      batches.begin(), batches.end(), [](const ObservationBatch& b) { return b.kind == ObservationBatch::Kind::kTouch; }));
  std::size_t applied = 0, touches = 0;
  if (progress) progress(applied, total);
  for (const ObservationBatch& b : batches) {
    if (b.kind != ObservationBatch::Kind::kTouch) continue;
    const TouchUpdate update = applyTouch(model, b.contacts, b.free_space, touch);
    // A touch that adds nothing now (e.g. all of it refused) is no reason to fail the rebuild.
    if (update.ok) ++touches;
    if (progress) progress(++applied, total);
  }
  report.message = "rebuilt from the view and " + std::to_string(touches) + " touch(es)";
  return report;
}

}  // namespace

FitReport ObservationHistory::rebuild(SurfaceModel& model, const TouchObservationConfig& touch,
                                      const RebuildProgress& progress) const {
  return rebuildFrom(batches_, touch, model, progress);
}

bool ObservationHistory::remove(const std::vector<std::uint32_t>& ids, const TouchObservationConfig& touch,
                                std::unique_ptr<SurfaceModel>* model, std::string* error,
                                const RebuildProgress& progress) {
  if (ids.empty()) {
    *error = "no batch to remove";
    return false;
  }
  for (const std::uint32_t id : ids) {
    const auto found = find(id);
    if (found == batches_.end()) {
      *error = "no batch " + std::to_string(id) + " (removed already, or never added)";
      return false;
    }
    if (found->kind == ObservationBatch::Kind::kView) {
      *error = "batch " + std::to_string(id) + " is the view: send a new view, or reset";
      return false;
    }
  }
  std::vector<ObservationBatch> kept;
  for (const ObservationBatch& b : batches_)
    if (std::find(ids.begin(), ids.end(), b.id) == ids.end()) kept.push_back(b);
  std::unique_ptr<SurfaceModel> rebuilt = (*model)->clone();
  const FitReport report = rebuildFrom(kept, touch, *rebuilt, progress);
  if (!report.ok) {
    *error = "the model without them failed to fit, nothing removed: " + report.message;
    return false;
  }
  *model = std::move(rebuilt);
  batches_ = std::move(kept);
  return true;
}

}  // namespace gpatlas_core
