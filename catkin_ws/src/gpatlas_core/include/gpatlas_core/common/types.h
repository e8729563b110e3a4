#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace gpatlas_core {

using Vector3 = Eigen::Vector3d;
using Points3 = Eigen::Matrix3Xd;  // one point per column, metres

// Where a training point came from; kept so that displays and reports can tell vision from
// touch, and so that free-space points can be treated differently from surface points.
// kViewSupport: the table the camera saw beside the object (sampleSupportFreeSpace); like
// kVision it belongs to the view, and a new view replaces it.
enum class PointSource : std::uint8_t { kVision = 0, kTouch = 1, kFreeSpace = 2, kPseudo = 3, kViewSupport = 4 };

// True for the data a camera view gave (vision and the table beside the object).
inline bool fromView(PointSource source) { return source == PointSource::kVision || source == PointSource::kViewSupport; }

const char* toString(PointSource source);

// `count` evenly spread directions on the unit sphere (Fibonacci lattice): deterministic and
// isotropic (the GP's outside pseudo-points, the view hull's support planes).
std::vector<Vector3> fibonacciSphere(int count);

// The q-quantile of `values` but NaNs as one of them: the element of rank min(n - 1, floor(q n))
// (q 0.5: the upper middle of an even count); NaN when there is none. Position calibration's scale is a
// quantile of held-out ratios, so it takes one of them.
double quantile(std::vector<double> values, double q);
// The median of the finite values, the mean of the two middle ones for an even count; NaN when
// there is none.
double median(std::vector<double> values);

// Training label of a point: on the surface (f = 0), outside (f = +1) or inside (f = -1).
enum class PointLabel : std::int8_t { kInside = -1, kSurface = 0, kOutside = 1 };

// One observation in world coordinates (metres). noise_sigma is the standard deviation of the
// observation of f at this point, in the model's normalised units of f.
struct TrainingPoint {
  Vector3 position{Vector3::Zero()};
  PointLabel label{PointLabel::kSurface};
  double noise_sigma{0.0};
  PointSource source{PointSource::kVision};
  // When finite, replaces the label's target (-1/0/+1): plain GP regression on other data,
  // e.g. samples drawn from a known kernel in the model's tests.
  double target_override{std::numeric_limits<double>::quiet_NaN()};
  // For an outside (inside) point: the distance (metres) to the nearest known surface point.
  // The model then uses min(1, distance / scale) (its negative) as the target, in its current
  // frame (see GpisModel::nearestSurfaceDistance); NaN keeps the label's +1 (-1).
  double surface_distance_m{std::numeric_limits<double>::quiet_NaN()};
  // Non-zero: the point observes the slope of f along this direction (made unit by the model)
  // instead of f itself, e.g. a probe's measured outward normal at a contact. Its target is +1
  // per normalised unit (that of a signed distance in the model's frame, as the distance-labelled
  // free space assumes; target_override replaces it). Such a point does not count as surface
  // data (centroid, scale, evidence): the contact it comes with does.
  Vector3 slope_direction{Vector3::Zero()};
  // For a probe's contact: how far (metres) it lay from the surface the model predicted before
  // the touch (|mean| / |gradient| there); NaN when unknown. The evidence rule trusts the
  // surroundings of a contact the model did not predict less (EvidenceRule::surprise_distance_m).
  double prediction_error_m{std::numeric_limits<double>::quiet_NaN()};
};

// True for a point that observes f's slope (TrainingPoint::slope_direction), not its value.
inline bool observesSlope(const TrainingPoint& point) { return (point.slope_direction.array() != 0.0).any(); }
// A surface point that observes f = 0 (the data that place and scale the model's frame).
inline bool isSurfaceValue(const TrainingPoint& point) {
  return point.label == PointLabel::kSurface && !observesSlope(point);
}
// The same observed slope direction (both zero for values). Directions are compared with a
// tolerance: the model makes them unit, which can change their last bits.
inline bool sameSlopeDirection(const TrainingPoint& a, const TrainingPoint& b) {
  return (a.slope_direction - b.slope_direction).squaredNorm() <= 1e-18;
}

// A contact measured by a probe: a point on the surface and, if the probe can tell, the
// surface normal there (zero vector when unknown).
struct Contact {
  Vector3 position{Vector3::Zero()};
  Vector3 normal{Vector3::Zero()};
};

// A touch to execute: an ordered path on the predicted surface with the direction each waypoint
// is approached from (the probe moves along -normal: the predicted outward normal, or one
// tilted from it where the approach along the normal is blocked, approach/max_tilt_deg)
// and the predicted variance at each waypoint.
struct Touch {
  enum class Kind : std::uint8_t { kPoke = 0, kSlide = 1 };
  Kind kind{Kind::kPoke};
  std::vector<Vector3> points;
  std::vector<Vector3> normals;
  std::vector<double> variances;  // in the model's reported (paper-equivalent) units
  std::string strategy;
  // A poke aimed into space no sensor has observed (the frontier strategy's), not at predicted
  // surface: finding nothing there is a result, the free space along its path, not a failed touch.
  bool explores_unknown{false};
  // How the probe's tip gets there and back (Algorithm 2's APPROACHTO and MOVEAWAY), when
  // planned (TouchApproacher): from the rest to the approach pose in front of approachTarget,
  // and from the approach pose in front of retreatTarget back to the rest, world frame. The
  // probe points along -normal of its target on the way. Empty: not planned; the probe then
  // moves in a straight line.
  std::vector<Vector3> approach_path;
  std::vector<Vector3> retreat_path;
  // The same motions for the arm that holds the probe, when planned for it: joint positions
  // (the arm's chain order) from the rest to the approach pose and back. approach_path and
  // retreat_path then hold the tip at these configurations.
  std::vector<Eigen::VectorXd> approach_joints;
  std::vector<Eigen::VectorXd> retreat_joints;
};

// The waypoint a touch's probe goes to first (a poke's target, a slide's first waypoint) and
// the one it leaves from (a poke's target, a slide's last waypoint). The touch must have one.
std::size_t approachTarget(const Touch& touch);
std::size_t retreatTarget(const Touch& touch);

// The surface points a touch aims at: a poke's target (its path's end), every waypoint of a
// slide. They count as evidence once touched, whatever the probe found
// (EvidenceState::attempted_targets).
std::vector<Vector3> aimedPoints(const Touch& touch);

}  // namespace gpatlas_core
