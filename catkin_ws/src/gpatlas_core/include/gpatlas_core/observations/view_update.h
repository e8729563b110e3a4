#pragma once

// A camera view's training data into a model: the twin of applyTouch (touch_training.h). The GP
// model nodelet and gpatlas_bench both build their model from a view with applyView.

#include "gpatlas_core/common/types.h"
#include "gpatlas_core/model/position_uncertainty.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/observations/occluded_interior.h"
#include "gpatlas_core/observations/touch_training.h"

#include <cstddef>
#include <optional>
#include <vector>

namespace gpatlas_core {

// What fitting a model to a new view did.
struct ViewUpdate {
  // False when the fit failed: the model is then unchanged, and not calibrated.
  bool ok{false};
  FitReport fit;
  // The touches' observations the model held (every one not from a view), kept in the fit.
  std::size_t touch_points_kept{0};
  // The new view's occluded-interior guesses that those touches contradicted.
  InteriorRetraction retraction;
  // Set when calibration was asked for and the fit succeeded.
  std::optional<PositionCalibration> calibration;
};

// Fits `model` from scratch to a view's training data (buildViewTraining) and the touches it
// holds: the previous view's points are replaced, the touches' points stay. The touches first
// retract the new view's occluded-interior guesses they contradict
// (TouchObservationConfig::guess_min_depth_fraction of the model's scale), as each touch did to
// the previous view's: a new view must not bring back a cavity's lid a touch took away. A model
// not fitted yet takes the view alone. Then, with `calibration` (null or 0 folds: none), its position sd is
// calibrated (calibratePositionSd; a failed calibration sets the scale to 1), with the tests of the
// touches made so far; each later touch refits it (addTouchCalibration).
ViewUpdate applyView(SurfaceModel& model, const std::vector<TrainingPoint>& view_training,
                     const TouchObservationConfig& touch, const PositionCalibrationConfig* calibration = nullptr);

}  // namespace gpatlas_core
