#include "probe_sim/probe.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace probe_sim {

namespace {

// Points start + k * spacing * direction for k = 0, 1, ... up to length (inclusive).
void appendSamples(const Eigen::Vector3d& start, const Eigen::Vector3d& direction, double length,
                   double spacing, std::vector<Eigen::Vector3d>& out) {
  if (length < 0.0) return;
  const auto count = static_cast<int>(std::floor(length / spacing + 1e-9));
  for (int k = 0; k <= count; ++k) out.push_back(start + (k * spacing) * direction);
}

void checkStrokeConfig(double start_offset, double spacing, double margin, double noise,
                       const char* model) {
  if (!(start_offset > 0.0) || !(spacing > 0.0) || !(margin >= 0.0) || !(noise >= 0.0)) {
    throw std::runtime_error(std::string(model) +
                             " probe: start offset and free-space spacing must be > 0, margin "
                             "and noise >= 0");
  }
}

Eigen::Vector3d gaussianOffset(double sigma, std::mt19937& rng) {
  if (sigma <= 0.0) return Eigen::Vector3d::Zero();
  std::normal_distribution<double> noise(0.0, sigma);
  const double x = noise(rng), y = noise(rng), z = noise(rng);
  return Eigen::Vector3d(x, y, z);
}

std::string kindsToText(unsigned kinds) {
  std::string text;
  for (SurfaceKind kind : {SurfaceKind::kObject, SurfaceKind::kTable, SurfaceKind::kObstacle}) {
    if (kinds & static_cast<unsigned>(kind)) {
      text += (text.empty() ? "" : "/") + std::string(toString(kind));
    }
  }
  return text;
}

}  // namespace

// ================================================================ ray

RayProbe::RayProbe(const Config& config) : config_(config), rng_(config.seed) {
  checkStrokeConfig(config_.start_offset_m, config_.free_space_spacing_m,
                    config_.free_space_margin_m, config_.position_noise_m, "ray");
}

ProbeStroke RayProbe::stroke(const Scene& scene, const Eigen::Vector3d& waypoint,
                             const Eigen::Vector3d& outward_normal) {
  ProbeStroke result;
  const Eigen::Vector3d n = outward_normal.normalized();
  const double d = config_.start_offset_m;
  const Eigen::Vector3d start = waypoint + d * n;
  const RayHit hit = scene.castRay(start, waypoint - d * n);
  if (!hit.hit) {
    appendSamples(start, -n, 2.0 * d, config_.free_space_spacing_m, result.free_space);
    return result;
  }
  appendSamples(start, -n, hit.distance - config_.free_space_margin_m,
                config_.free_space_spacing_m, result.free_space);
  result.touched = hit.kind;
  result.contact.position = hit.point + gaussianOffset(config_.position_noise_m, rng_);
  result.contact.normal = hit.normal;
  return result;
}

// ================================================================ sphere

SphereProbe::SphereProbe(const Config& config) : config_(config), rng_(config.seed) {
  checkStrokeConfig(config_.start_offset_m, config_.free_space_spacing_m,
                    config_.free_space_margin_m, config_.position_noise_m, "sphere");
  if (!(config_.radius_m > 0.0)) throw std::runtime_error("sphere probe: radius must be > 0");
}

ProbeStroke SphereProbe::stroke(const Scene& scene, const Eigen::Vector3d& waypoint,
                                const Eigen::Vector3d& outward_normal) {
  ProbeStroke result;
  const Eigen::Vector3d n = outward_normal.normalized();
  const double d = config_.start_offset_m;
  const Eigen::Vector3d start = waypoint + d * n;
  // A sweep that starts in contact has no meaningful first contact (Bullet reports fraction 0
  // or nothing), and a real fingertip could not have got there.
  const unsigned start_overlap = scene.sphereOverlaps(config_.radius_m, start);
  if (start_overlap != 0) {
    result.failure = "probe start position overlaps the " + kindsToText(start_overlap);
    return result;
  }
  const SweepHit hit = scene.sweepSphere(config_.radius_m, start, waypoint - d * n);
  if (!hit.hit) {
    appendSamples(start, -n, 2.0 * d, config_.free_space_spacing_m, result.free_space);
    return result;
  }
  appendSamples(start, -n, hit.fraction * 2.0 * d - config_.free_space_margin_m,
                config_.free_space_spacing_m, result.free_space);
  result.touched = hit.kind;
  result.contact.position = hit.witness_point + gaussianOffset(config_.position_noise_m, rng_);
  result.contact.normal = hit.normal;
  return result;
}

// ================================================================ factory

std::vector<std::string> probeModelNames() { return {"ray", "sphere"}; }

std::unique_ptr<ProbeModel> makeProbeModel(const std::string& name,
                                           const ProbeModelConfig& config) {
  if (name == "ray") return std::make_unique<RayProbe>(config.ray);
  if (name == "sphere") return std::make_unique<SphereProbe>(config.sphere);
  throw std::runtime_error("unknown probe model '" + name + "' (known: ray, sphere)");
}

// ================================================================ slides

std::vector<ProbeAttempt> interpolateSlide(const std::vector<Eigen::Vector3d>& points,
                                           const std::vector<Eigen::Vector3d>& normals,
                                           double step_m) {
  std::vector<ProbeAttempt> attempts;
  if (points.empty()) return attempts;
  std::vector<double> arc_length = {0.0};
  for (std::size_t i = 1; i < points.size(); ++i) {
    arc_length.push_back(arc_length.back() + (points[i] - points[i - 1]).norm());
  }
  const double total = arc_length.back();
  const auto intervals = static_cast<std::size_t>(std::ceil(total / step_m - 1e-9));
  if (intervals == 0) return {{points.front(), normals.front().normalized()}};
  std::size_t segment = 0;
  for (std::size_t k = 0; k <= intervals; ++k) {
    const double s = total * static_cast<double>(k) / static_cast<double>(intervals);
    while (segment + 2 < points.size() && arc_length[segment + 1] < s) ++segment;
    const double segment_length = arc_length[segment + 1] - arc_length[segment];
    const double t =
        segment_length > 0.0 ? std::clamp((s - arc_length[segment]) / segment_length, 0.0, 1.0)
                             : 0.0;
    const Eigen::Vector3d point = (1.0 - t) * points[segment] + t * points[segment + 1];
    const Eigen::Vector3d n0 = normals[segment].normalized();
    const Eigen::Vector3d n1 = normals[segment + 1].normalized();
    Eigen::Vector3d normal = (1.0 - t) * n0 + t * n1;
    // Opposite neighbouring normals blend to zero; keep the nearer waypoint's normal then.
    normal = normal.norm() > 1e-9 ? Eigen::Vector3d(normal.normalized()) : (t < 0.5 ? n0 : n1);
    attempts.push_back({point, normal});
  }
  return attempts;
}

// ================================================================ prober

unsigned armCollisions(const Arm& arm, const Scene& scene, const Eigen::VectorXd& joints) {
  std::vector<Capsule> capsules;
  for (const gpatlas_motion::LinkCapsule& link : arm.linkCapsules(joints)) capsules.push_back({link.a, link.b, link.radius});
  unsigned kinds = 0;
  for (unsigned k : scene.capsuleOverlaps(capsules, kAllSurfaces, arm.config().collision_tolerance_m)) kinds |= k;
  return kinds;
}

namespace {

// The separate runs of colliding samples along a polyline: each stretch from one point to the
// next is sampled with steps(from, to) steps, and a stretch's last sample is the next one's first.
template <typename Point, typename Steps, typename Collides>
int countContactRuns(const std::vector<Point>& path, const Steps& steps, const Collides& collides) {
  int contacts = 0;
  bool in_contact = false;
  for (std::size_t i = 0; i < path.size(); ++i) {
    const Point& from = path[i];
    const Point& to = i + 1 < path.size() ? path[i + 1] : path[i];
    const int n = std::max(1, steps(from, to));
    const int last = i + 1 < path.size() ? n - 1 : n;
    for (int s = 0; s <= last; ++s) {
      const bool hit = collides(Point(from + (to - from) * (static_cast<double>(s) / n)));
      contacts += hit && !in_contact ? 1 : 0;
      in_contact = hit;
    }
  }
  return contacts;
}

}  // namespace

int countPathContacts(const Scene& scene, const gpatlas_core::ProbeGeometry& body,
                      const std::vector<Eigen::Vector3d>& tip_path, const Eigen::Vector3d& direction, double step_m) {
  const Eigen::Vector3d d = direction.normalized();
  const auto collides = [&](const Eigen::Vector3d& tip) {
    if (scene.sphereOverlaps(body.tip_radius_m, tip) != 0) return true;
    Capsule shaft;
    shaft.a = tip - body.tip_radius_m * d;
    shaft.b = tip - (body.tip_radius_m + body.shaft_length_m) * d;
    shaft.radius = body.shaft_radius_m;
    return scene.capsuleOverlaps({shaft}).front() != 0;
  };
  const auto steps = [step_m](const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
    return static_cast<int>(std::ceil((to - from).norm() / step_m));
  };
  return countContactRuns(tip_path, steps, collides);
}

int countArmPathContacts(const Scene& scene, const Arm& arm, const gpatlas_core::ProbeGeometry& body,
                         const std::vector<Eigen::VectorXd>& joint_path, double step_m) {
  const auto collides = [&](const Eigen::VectorXd& q) {
    if (armCollisions(arm, scene, q) != 0) return true;
    const Eigen::Isometry3d tip = arm.forwardKinematics(q);
    return countPathContacts(scene, body, {tip.translation()}, tip.linear().col(2), step_m) != 0;
  };
  // No point of the arm moves farther than chainLength() times the joints' summed motion.
  const double length = arm.chainLength();
  const auto steps = [length, step_m](const Eigen::VectorXd& from, const Eigen::VectorXd& to) {
    return static_cast<int>(std::ceil(length * (to - from).lpNorm<1>() / step_m));
  };
  return countContactRuns(joint_path, steps, collides);
}

SimulatedProber::SimulatedProber(std::shared_ptr<const Scene> scene,
                                 std::unique_ptr<ProbeModel> model, const Config& config)
    : scene_(std::move(scene)), model_(std::move(model)), config_(config) {
  if (!scene_ || !model_) throw std::runtime_error("SimulatedProber: scene and model are required");
  if (!(config_.slide_step_m > 0.0)) {
    throw std::runtime_error("SimulatedProber: slide_step_m must be > 0");
  }
  if (!(config_.motion_check_step_m > 0.0) || !config_.rest_tip_position.allFinite())
    throw std::runtime_error("SimulatedProber: motion_check_step_m must be > 0 and the rest position finite");
}

std::string SimulatedProber::validate(const gpatlas_core::Touch& touch) const {
  if (touch.points.empty()) return "empty touch: no waypoints";
  if (touch.normals.size() != touch.points.size()) {
    return "touch has " + std::to_string(touch.points.size()) + " waypoints but " +
           std::to_string(touch.normals.size()) + " normals";
  }
  for (std::size_t i = 0; i < touch.points.size(); ++i) {
    if (!touch.points[i].allFinite()) return "waypoint " + std::to_string(i) + " is not finite";
    if (!touch.normals[i].allFinite() || touch.normals[i].norm() < 1e-9) {
      return "normal " + std::to_string(i) + " is zero or not finite";
    }
  }
  for (const auto* path : {&touch.approach_path, &touch.retreat_path})
    for (const Eigen::Vector3d& p : *path)
      if (!p.allFinite()) return std::string(path == &touch.approach_path ? "approach" : "retreat") + " path is not finite";
  for (const auto* path : {&touch.approach_joints, &touch.retreat_joints})
    for (const Eigen::VectorXd& q : *path)
      if (!q.allFinite() || !arm_ || q.size() != arm_->jointCount())
        return std::string(path == &touch.approach_joints ? "approach" : "retreat") +
               " joint path is not finite or not for this arm (" + (arm_ ? std::to_string(arm_->jointCount()) : "no") +
               " joints)";
  if (touch.kind == gpatlas_core::Touch::Kind::kSlide) {
    double length = 0.0;
    for (std::size_t i = 1; i < touch.points.size(); ++i) {
      length += (touch.points[i] - touch.points[i - 1]).norm();
    }
    if (length / config_.slide_step_m > static_cast<double>(config_.max_slide_attempts)) {
      return "slide path of " + std::to_string(length) + " m needs more than " +
             std::to_string(config_.max_slide_attempts) + " attempts";
    }
  }
  return "";
}

void SimulatedProber::setArm(std::shared_ptr<const Arm> arm) {
  arm_rest_ = arm ? gpatlas_motion::armRestConfiguration(*arm, config_.rest_tip_position) : Eigen::VectorXd();
  arm_ = std::move(arm);
}

std::string SimulatedProber::moveArm(const gpatlas_core::Touch& touch, const std::vector<ProbeAttempt>& waypoints,
                                     gpatlas_core::ProbeResult* result) {
  // The robot knows its own kinematics, not the true scene: no collision check in the solver.
  std::vector<Eigen::VectorXd> at_waypoints;
  Eigen::VectorXd previous = touch.approach_joints.empty() ? arm_rest_ : touch.approach_joints.back();
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    const ProbeAttempt& w = waypoints[i];
    const Arm::IkResult ik = arm_->solveApproach(w.point + model_->tipStandoff() * w.normal, -w.normal, nullptr, &previous);
    if (!ik.reached) return "unreachable" + (waypoints.size() > 1 ? " at waypoint " + std::to_string(i) : std::string());
    previous = ik.joints;
    at_waypoints.push_back(ik.joints);
  }
  const auto straight = [&](const ProbeAttempt& w, const Eigen::VectorXd& seed, std::string* problem) {
    const Arm::IkResult ik = arm_->solveApproach(w.point + model_->startOffset() * w.normal, -w.normal, nullptr, &seed);
    if (!ik.reached) *problem = "unreachable approach pose";
    return std::vector<Eigen::VectorXd>{arm_rest_, ik.joints};
  };
  std::string problem;
  const std::vector<Eigen::VectorXd> approach =
      !touch.approach_joints.empty() ? touch.approach_joints : straight(waypoints.front(), at_waypoints.front(), &problem);
  std::vector<Eigen::VectorXd> retreat = touch.retreat_joints;
  if (retreat.empty()) {
    retreat = straight(waypoints.back(), at_waypoints.back(), &problem);
    std::reverse(retreat.begin(), retreat.end());
  }
  if (!problem.empty()) return problem;
  result->approach_collisions =
      countArmPathContacts(*scene_, *arm_, config_.body, approach, config_.motion_check_step_m);
  result->retreat_collisions = countArmPathContacts(*scene_, *arm_, config_.body, retreat, config_.motion_check_step_m);
  last_arm_solutions_ = approach;
  last_arm_solutions_.insert(last_arm_solutions_.end(), at_waypoints.begin(), at_waypoints.end());
  last_arm_solutions_.insert(last_arm_solutions_.end(), retreat.begin(), retreat.end());
  return "";
}

gpatlas_core::ProbeResult SimulatedProber::probe(const gpatlas_core::Touch& touch) {
  gpatlas_core::ProbeResult result;
  last_arm_solutions_.clear();
  result.reason = validate(touch);
  if (!result.reason.empty()) return result;

  const bool slide = touch.kind == gpatlas_core::Touch::Kind::kSlide;
  std::vector<ProbeAttempt> waypoints;
  for (std::size_t i = slide ? 0 : touch.points.size() - 1; i < touch.points.size(); ++i) {
    waypoints.push_back({touch.points[i], touch.normals[i].normalized()});
  }
  const std::vector<ProbeAttempt> attempts =
      slide ? interpolateSlide(touch.points, touch.normals, config_.slide_step_m) : waypoints;

  // The way there and back: planned, or straight from and to the rest.
  const ProbeAttempt& first = waypoints.front();
  const ProbeAttempt& last = waypoints.back();
  if (arm_) {
    result.reason = moveArm(touch, waypoints, &result);
    if (!result.reason.empty()) return result;
  } else {
    const std::vector<Eigen::Vector3d> approach =
        !touch.approach_path.empty() ? touch.approach_path
                                     : std::vector<Eigen::Vector3d>{config_.rest_tip_position,
                                                                    first.point + model_->startOffset() * first.normal};
    const std::vector<Eigen::Vector3d> retreat =
        !touch.retreat_path.empty() ? touch.retreat_path
                                    : std::vector<Eigen::Vector3d>{last.point + model_->startOffset() * last.normal,
                                                                   config_.rest_tip_position};
    result.approach_collisions = countPathContacts(*scene_, config_.body, approach, -first.normal,
                                                   config_.motion_check_step_m);
    result.retreat_collisions = countPathContacts(*scene_, config_.body, retreat, -last.normal,
                                                  config_.motion_check_step_m);
  }

  unsigned other_surfaces = 0;
  std::string stroke_failure;
  for (const ProbeAttempt& attempt : attempts) {
    ProbeStroke stroke = model_->stroke(*scene_, attempt.point, attempt.normal);
    if (!stroke.failure.empty()) stroke_failure = stroke.failure;
    result.free_space.insert(result.free_space.end(), stroke.free_space.begin(),
                             stroke.free_space.end());
    if (stroke.touched == SurfaceKind::kObject) {
      result.contacts.push_back(stroke.contact);
    } else if (stroke.touched != SurfaceKind::kNone) {
      other_surfaces |= static_cast<unsigned>(stroke.touched);
    }
  }
  result.success = !result.contacts.empty();
  if (!result.success) {
    if (!stroke_failure.empty()) {
      result.reason = stroke_failure;
    } else if (other_surfaces != 0) {
      result.reason = "no contact with the object (touched the " + kindsToText(other_surfaces) + ")";
    } else {
      result.reason = "no contact";
    }
  }
  return result;
}

}  // namespace probe_sim
