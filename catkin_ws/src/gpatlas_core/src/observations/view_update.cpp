#include "gpatlas_core/observations/view_update.h"

namespace gpatlas_core {

ViewUpdate applyView(SurfaceModel& model, const std::vector<TrainingPoint>& view_training,
                     const TouchObservationConfig& touch, const PositionCalibrationConfig* calibration) {
  ViewUpdate update;
  std::vector<TrainingPoint> data = view_training;
  std::vector<Vector3> touch_evidence;
  for (const TrainingPoint& point : model.observations()) {
    if (fromView(point.source)) continue;
    data.push_back(point);
    ++update.touch_points_kept;
    if (point.source == PointSource::kFreeSpace || isSurfaceValue(point)) touch_evidence.push_back(point.position);
  }
  // The touches' kept (thinned) contacts and free space stand for the touches here.
  if (model.isFitted())
    update.retraction =
        retractContradictedInterior(&data, touch_evidence, touch.guess_min_depth_fraction * model.scale());
  update.fit = model.fit(data);
  update.ok = update.fit.ok;
  if (update.ok && calibration && calibration->folds > 0) {
    update.calibration = calibratePositionSd(model, *calibration);
    // A scale fitted to the previous view says nothing about this one: uncalibrated (vague)
    // instead, and touches do not calibrate it until a view does.
    if (!update.calibration->ok) {
      model.setPositionSdScale(1.0);
      model.setPositionSdEvidence({});
    }
  }
  return update;
}

}  // namespace gpatlas_core
