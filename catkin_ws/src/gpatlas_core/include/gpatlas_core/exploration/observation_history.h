#pragma once

#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/common/types.h"

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gpatlas_core {

// One batch of observations as it arrived: the view's training data, or one touch's raw
// contacts and free space (before the gate and the thinning).
struct ObservationBatch {
  enum class Kind : std::uint8_t { kView = 0, kTouch = 1 };
  std::uint32_t id{0};
  Kind kind{Kind::kTouch};
  std::vector<TrainingPoint> view_training;  // kView
  std::vector<Contact> contacts;             // kTouch
  std::vector<Vector3> free_space;           // kTouch
};

// Called as a rebuild goes: (touches applied so far, touches to apply).
using RebuildProgress = std::function<void(std::size_t applied, std::size_t total)>;

// What a model was built from, as numbered batches, so that one can be taken back out: a
// wrong touch is removed without losing the others. Ids count from 1 and are never reused.
class ObservationHistory {
 public:
  // A new view replaces the previous one; the touches stay.
  std::uint32_t setView(std::vector<TrainingPoint> view_training);
  std::uint32_t addTouch(std::vector<Contact> contacts, std::vector<Vector3> free_space);
  void clear();

  const std::vector<ObservationBatch>& batches() const { return batches_; }
  bool contains(std::uint32_t id) const;
  std::size_t touchCount() const;
  // The ids of the last `n` touches, oldest first.
  std::vector<std::uint32_t> lastTouches(std::size_t n) const;

  // Builds `model` as if the batches with these ids had never come: the view's training data
  // fitted, then every other touch applied in order (applyTouch), so that thinning, the gate and
  // retracted guesses are what the remaining data give. On success `*model` is replaced by the
  // rebuilt one (a model of the same kind: clone() of it, refitted) and the batches are dropped
  // from the history; on failure (an unknown id, the view itself, or a fit that fails) the model
  // and the history are unchanged and `error` says why.
  // A rebuild re-applies every touch kept, seconds for a hundred: `progress`, when given, is called
  // after the view's fit and after each touch with the touches applied so far and their number.
  bool remove(const std::vector<std::uint32_t>& ids, const TouchObservationConfig& touch,
              std::unique_ptr<SurfaceModel>* model, std::string* error, const RebuildProgress& progress = {});

  // The model the history gives: the view fitted, then the touches applied in order. Fails
  // without a view.
  FitReport rebuild(SurfaceModel& model, const TouchObservationConfig& touch,
                    const RebuildProgress& progress = {}) const;

 private:
  std::vector<ObservationBatch>::const_iterator find(std::uint32_t id) const;
  std::vector<ObservationBatch> batches_;  // the view (if any) first, then touches in order
  std::uint32_t next_id_{1};
};

}  // namespace gpatlas_core
