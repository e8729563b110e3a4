#pragma once

#include "probe_sim/scene.h"

#include <gpatlas_motion/arm.h>

#include <gpatlas_motion/approach_config.h>
#include <gpatlas_core/exploration/prober.h>
#include <gpatlas_core/common/types.h>

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace probe_sim {

using gpatlas_motion::Arm;
using gpatlas_motion::ArmConfig;

// SurfaceKind bits of the scene surfaces that the arm's link capsules penetrate (by more than
// ArmConfig::collision_tolerance_m) in the configuration `joints`.
unsigned armCollisions(const Arm& arm, const Scene& scene, const Eigen::VectorXd& joints);

// Outcome of one straight probing motion along -n through a waypoint.
struct ProbeStroke {
  SurfaceKind touched = SurfaceKind::kNone;  // what stopped the probe, if anything
  gpatlas_core::Contact contact;             // valid when touched != kNone
  // A pad's contact with the object: its points and normals (`contact` is the first of them to
  // touch). Empty for the single-point probes.
  std::vector<gpatlas_core::Contact> patch;
  std::vector<gpatlas_core::PadPress> pad;  // the pad at its deepest press, when it touched anything
  std::vector<Eigen::Vector3d> free_space;   // positions the probe passed freely
  std::string failure;                       // why the stroke could not be made at all
  std::string note;                          // what a usable stroke met besides the object
};

// A probe geometry. A stroke starts at waypoint + d * n and moves towards waypoint - d * n,
// where n is the unit outward normal and d the model's start offset.
class ProbeModel {
 public:
  virtual ~ProbeModel() = default;
  virtual std::string name() const = 0;
  virtual ProbeStroke stroke(const Scene& scene, const Eigen::Vector3d& waypoint,
                             const Eigen::Vector3d& outward_normal) = 0;
  // Distance from the touched surface to the arm's tip frame while touching (0 for a ray,
  // the radius for a sphere centred on the tip frame).
  virtual double tipStandoff() const = 0;
  // d above: how far out along the normal a stroke starts (the approach pose).
  virtual double startOffset() const = 0;
};

struct RayProbeConfig {
  double start_offset_m = 0.10;
  double free_space_spacing_m = 0.01;
  double free_space_margin_m = 0.005;  // no free-space sample closer than this to the hit
  double position_noise_m = 0.0;       // Gaussian, per axis, on the contact position
  std::uint32_t seed = 1;
};

// The paper's validation protocol: an infinitely thin ray through the waypoint.
class RayProbe : public ProbeModel {
 public:
  using Config = RayProbeConfig;
  explicit RayProbe(const Config& config = Config());
  std::string name() const override { return "ray"; }
  ProbeStroke stroke(const Scene& scene, const Eigen::Vector3d& waypoint,
                     const Eigen::Vector3d& outward_normal) override;
  double tipStandoff() const override { return 0.0; }
  double startOffset() const override { return config_.start_offset_m; }

 private:
  Config config_;
  std::mt19937 rng_;
};

struct SphereProbeConfig {
  double radius_m = 0.02;
  double start_offset_m = 0.10;
  double free_space_spacing_m = 0.01;
  double free_space_margin_m = 0.005;  // between free-space centres and the contact centre
  double position_noise_m = 0.0;
  std::uint32_t seed = 1;
};

// A spherical fingertip swept along the stroke; the contact is Bullet's witness point on the
// surface and free space is where the sphere centre went before contact.
class SphereProbe : public ProbeModel {
 public:
  using Config = SphereProbeConfig;
  explicit SphereProbe(const Config& config = Config());
  std::string name() const override { return "sphere"; }
  ProbeStroke stroke(const Scene& scene, const Eigen::Vector3d& waypoint,
                     const Eigen::Vector3d& outward_normal) override;
  double tipStandoff() const override { return config_.radius_m; }
  double startOffset() const override { return config_.start_offset_m; }

 private:
  Config config_;
  std::mt19937 rng_;
};

struct PatchProbeConfig {
  // The pad: a square elastomer of this side, flat, or a spherical cap of this radius of
  // curvature (0: flat) whose centre touches first.
  double pad_size_m = 0.02;
  double pad_curvature_radius_m = 0.0;
  // Pressed along the touch's normal this far past its first contact with anything.
  double indentation_m = 0.001;
  // The contact is rendered as a depth image over the pad, one ray per pixel of this side...
  double resolution_m = 0.00025;
  // ... and reported as contact points on a grid of this spacing (a multiple of the pixel;
  // 0: every pixel), each with its normal from the depth image's gradient at full resolution.
  double point_spacing_m = 0.001;
  // A passive gimbal between pad and mount: after the first contact the pad turns about its centre
  // toward the mean surface normal under the pad, by at most this angle, and presses on (0: rigid).
  double gimbal_range_deg = 0.0;
  double depth_noise_m = 0.0;     // Gaussian, along the pad's normal, per pixel
  double normal_noise_deg = 0.0;  // Gaussian tilt of each reported normal
  double start_offset_m = 0.10;
  // Free space: along the pad centre's path up to free_space_margin_m before the first contact,
  // every free_space_spacing_m; and over the pressed pad, on a grid of that spacing, where
  // nothing lies within free_space_margin_m in front of it.
  double free_space_spacing_m = 0.01;
  double free_space_margin_m = 0.005;
  std::uint32_t seed = 1;
};

// A vision-based tactile sensor (GelSight, DIGIT and the like): a pad pressed along the touch's
// normal until `indentation_m` past its first contact. The pixels where the pressed pad reaches
// the object are the contact patch; their depth gives the points and its gradient the normals.
// The pad's tip frame is the pad's centre (no standoff).
class PatchProbe : public ProbeModel {
 public:
  using Config = PatchProbeConfig;
  explicit PatchProbe(const Config& config = Config());
  std::string name() const override { return "patch"; }
  ProbeStroke stroke(const Scene& scene, const Eigen::Vector3d& waypoint,
                     const Eigen::Vector3d& outward_normal) override;
  double tipStandoff() const override { return 0.0; }
  double startOffset() const override { return config_.start_offset_m; }
  // Half the pad's diagonal: the probe's body (its tip sphere) must enclose the pad.
  double padHalfDiagonal() const;

 private:
  struct PressOptions {
    double start_offset_m;  // the pad starts this far out along n from the waypoint
    Eigen::Vector3d* mean_contact_normal = nullptr;  // adds the mean surface normal under the contact
    double* first_travel_m = nullptr;                // the pad's travel at its first contact
    bool check_start = true;                         // refuse a start that overlaps the scene
  };
  // One press along n.
  ProbeStroke press(const Scene& scene, const Eigen::Vector3d& waypoint, const Eigen::Vector3d& n,
                    const PressOptions& options);
  // How far a point of a curved pad this far from its centre lies behind the centre (0: flat).
  double padRecess(double lateral_m) const;
  // Of the sphere about the pad's centre that holds the pad, curved or flat.
  double padBoundingRadius() const;

  Config config_;
  std::mt19937 rng_;
};

struct ProbeModelConfig {
  RayProbe::Config ray;
  SphereProbe::Config sphere;
  PatchProbe::Config patch;
};
std::vector<std::string> probeModelNames();
// "ray", "sphere" or "patch"; throws std::runtime_error for anything else.
std::unique_ptr<ProbeModel> makeProbeModel(const std::string& name,
                                           const ProbeModelConfig& config = ProbeModelConfig());

// One probing attempt of a slide: where and along which (unit, outward) normal.
struct ProbeAttempt {
  Eigen::Vector3d point;
  Eigen::Vector3d normal;
};

// Attempts spread evenly along the polyline, both ends included, at most step_m apart; normals
// are linearly interpolated and renormalised. Inputs must already be validated (finite, same
// sizes, non-zero normals).
std::vector<ProbeAttempt> interpolateSlide(const std::vector<Eigen::Vector3d>& points,
                                           const std::vector<Eigen::Vector3d>& normals,
                                           double step_m);

struct SimulatedProberConfig {
  double slide_step_m = 0.005;
  std::size_t max_slide_attempts = 20000;  // refuses absurd paths instead of looping for long
  // The judge of the way to a touch and back: the probe's body (the approach planner's,
  // approach/ in the YAML) moved along the touch's approach and retreat paths, or in a straight
  // line between the rest and the approach pose where the touch has none, pointing along the
  // target's -normal, checked against the true scene every motion_check_step_m.
  gpatlas_motion::ProbeGeometry body;
  Eigen::Vector3d rest_tip_position{0.7, 0.3, 0.4};
  double motion_check_step_m = 0.004;  // below the shaft's diameter: no crossing is missed
};

// Where the probe's body (a tip sphere and the shaft behind it, pointing along `direction`)
// penetrates the scene along a polyline of tip positions sampled every `step_m`: the number of
// separate contacts (a run of colliding samples counts once). `kinds` (optional) gets the
// SurfaceKind bits of what it met added.
int countPathContacts(const Scene& scene, const gpatlas_motion::ProbeGeometry& body,
                      const std::vector<Eigen::Vector3d>& tip_path, const Eigen::Vector3d& direction, double step_m,
                      unsigned* kinds = nullptr);

// Where the arm (its link capsules, ArmConfig) or the probe's body at its tip frame penetrates
// the scene along a joint-space polyline, sampled so that no point of the arm moves more than
// step_m between samples: the number of separate contacts (a run of colliding samples counts
// once). `kinds` (optional) gets the SurfaceKind bits of what it met added.
int countArmPathContacts(const Scene& scene, const Arm& arm, const gpatlas_motion::ProbeGeometry& body,
                         const std::vector<Eigen::VectorXd>& joint_path, double step_m, unsigned* kinds = nullptr);

// gpatlas_core::Prober on the simulated scene: a poke probes the last waypoint of the touch, a
// slide follows the path with an attempt every slide_step_m. The way there and back is judged
// (SimulatedProberConfig) and reported as approach and retreat collisions; the touch is made
// all the same, as a robot that felt a bump would go on. With an arm, the arm moves: along the
// touch's approach_joints and retreat_joints where planned, else in a straight joint motion
// between its rest and an inverse-kinematics solution at the approach pose; every waypoint
// needs such a solution or the touch is "unreachable". The arm's own collisions with the true
// scene are what it meets on the way, as on a real robot: they do not steer it.
class SimulatedProber : public gpatlas_core::Prober {
 public:
  using Config = SimulatedProberConfig;

  SimulatedProber(std::shared_ptr<const Scene> scene, std::unique_ptr<ProbeModel> model,
                  const Config& config = Config());

  // The arm rests with its tip at Config::rest_tip_position, pointing down
  // (gpatlas_motion::armRestConfiguration). Throws std::runtime_error when it cannot.
  void setArm(std::shared_ptr<const Arm> arm);
  const Eigen::VectorXd& armRest() const { return arm_rest_; }
  const ProbeModel& model() const { return *model_; }

  gpatlas_core::ProbeResult probe(const gpatlas_core::Touch& touch) override;

  // The arm's joint positions over the last touch, so that a caller can show the motion: the
  // approach from the rest, each probed waypoint in order, the retreat to the rest. Empty when
  // there is no arm or the last touch failed before every waypoint had a solution.
  const std::vector<Eigen::VectorXd>& lastArmSolutions() const { return last_arm_solutions_; }
  // What the last touch's way there and back met (SurfaceKind bits; 0: no collision).
  unsigned lastWayCollisionKinds() const { return last_way_kinds_; }

 private:
  // Empty when the touch is usable, else the reason it is not.
  std::string validate(const gpatlas_core::Touch& touch) const;
  // The arm's motion for the touch: its configuration at each waypoint and the way there and
  // back, judged; empty when every waypoint is reached, else why not.
  std::string moveArm(const gpatlas_core::Touch& touch, const std::vector<ProbeAttempt>& waypoints,
                      gpatlas_core::ProbeResult* result);

  std::shared_ptr<const Scene> scene_;
  std::unique_ptr<ProbeModel> model_;
  std::shared_ptr<const Arm> arm_;
  Eigen::VectorXd arm_rest_;
  Config config_;
  std::vector<Eigen::VectorXd> last_arm_solutions_;
  unsigned last_way_kinds_ = 0;
};

}  // namespace probe_sim
