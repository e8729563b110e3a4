#include "probe_sim/probe.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace probe_sim {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Below this tilt the gimbal leaves the pad as it pressed (a second press would repeat the first).
constexpr double kMinGimbalTilt = 0.5 * kPi / 180.0;

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

// ================================================================ patch

PatchProbe::PatchProbe(const Config& config) : config_(config), rng_(config.seed) {
  checkStrokeConfig(config_.start_offset_m, config_.free_space_spacing_m, config_.free_space_margin_m,
                    config_.depth_noise_m, "patch");
  const Config& c = config_;
  if (!(c.pad_size_m > 0.0) || !(c.resolution_m > 0.0) || !(c.resolution_m <= c.pad_size_m) ||
      !(c.indentation_m >= 0.0) || !(c.point_spacing_m >= 0.0) || !(c.normal_noise_deg >= 0.0) ||
      !(c.pad_curvature_radius_m >= 0.0) || !(c.gimbal_range_deg >= 0.0 && c.gimbal_range_deg <= 90.0))
    throw std::runtime_error(
        "patch probe: need pad_size_m > 0, 0 < resolution_m <= pad_size_m, and indentation_m, point_spacing_m, "
        "normal_noise_deg, pad_curvature_radius_m >= 0, and 0 <= gimbal_range_deg <= 90");
  if (c.pad_size_m / c.resolution_m > 2000.0)
    throw std::runtime_error("patch probe: more than 2000 x 2000 pixels over the pad (pad_size_m / resolution_m)");
  if (c.pad_curvature_radius_m > 0.0 && !(c.pad_curvature_radius_m > padHalfDiagonal()))
    throw std::runtime_error("patch probe: pad_curvature_radius_m must exceed half the pad's diagonal (" +
                             std::to_string(padHalfDiagonal()) + " m)");
  if (!(c.start_offset_m > c.indentation_m))
    throw std::runtime_error("patch probe: start_offset_m must exceed indentation_m");
}

double PatchProbe::padHalfDiagonal() const { return config_.pad_size_m / std::sqrt(2.0); }

ProbeStroke PatchProbe::stroke(const Scene& scene, const Eigen::Vector3d& waypoint,
                               const Eigen::Vector3d& outward_normal) {
  const Eigen::Vector3d n = outward_normal.normalized();
  const double range = config_.gimbal_range_deg * kPi / 180.0;
  if (!(range > 0.0)) return press(scene, waypoint, n, PressOptions{config_.start_offset_m});
  PressOptions rigid{config_.start_offset_m};
  Eigen::Vector3d settled = Eigen::Vector3d::Zero();
  double first_travel = 0.0;
  rigid.mean_contact_normal = &settled;
  rigid.first_travel_m = &first_travel;
  ProbeStroke first = press(scene, waypoint, n, rigid);
  if (first.touched != SurfaceKind::kObject || settled.isZero()) return first;
  const double tilt = std::atan2(n.cross(settled).norm(), n.dot(settled));
  if (tilt < kMinGimbalTilt) return first;
  // The gimbal turns the pad about its centre toward the surface under it, as far as its range
  // allows, and the pad presses on from there: from its centre at the first contact, backed off
  // along the turned axis just enough that its swung edge clears the surface.
  const Eigen::Vector3d pivot = waypoint + (config_.start_offset_m - first_travel) * n;
  const Eigen::Vector3d turned = Eigen::AngleAxisd(std::min(tilt, range), n.cross(settled).normalized()) * n;
  PressOptions settling{padBoundingRadius() * std::sin(tilt) + config_.indentation_m + config_.free_space_margin_m};
  settling.check_start = false;  // the pad turns in place: it does not come from elsewhere
  ProbeStroke second = press(scene, pivot, turned, settling);
  if (second.touched != SurfaceKind::kObject) {
    first.note += (first.note.empty() ? "" : "; ") + std::string("the gimbal could not settle the pad (") +
                  (second.failure.empty() ? "it lost the object" : second.failure) + ")";
    return first;
  }
  // The settled press gives the patch; the first press's approach was free space (its pressed
  // pad never was: the pad turned at the first contact).
  std::vector<Eigen::Vector3d> approach;
  appendSamples(waypoint + config_.start_offset_m * n, -n, first_travel - config_.free_space_margin_m,
                config_.free_space_spacing_m, approach);
  second.free_space.insert(second.free_space.begin(), approach.begin(), approach.end());
  return second;
}

double PatchProbe::padRecess(double lateral_m) const {
  const double r = config_.pad_curvature_radius_m;
  return r > 0.0 ? r - std::sqrt(r * r - lateral_m * lateral_m) : 0.0;
}

double PatchProbe::padBoundingRadius() const {
  const double h = padHalfDiagonal();
  return std::hypot(h, padRecess(h));
}

namespace {

// The pad's square grid of m x m pixels of side `pitch`, in its frame: u and v across the pad, n
// out of it.
struct PadPixels {
  Eigen::Vector3d u, v, n;
  int m;
  double pitch, size;
  PadPixels(const Eigen::Vector3d& normal, double size_m, double resolution_m)
      : u(normal.unitOrthogonal()), v(normal.cross(u)), n(normal),
        m(std::max(1, static_cast<int>(std::lround(size_m / resolution_m)))), pitch(size_m / m), size(size_m) {}
  // Pixel i's centre along u (or v), from the pad's centre.
  double coordinate(int i) const { return (i + 0.5) * pitch - 0.5 * size; }
  std::size_t index(int i, int j) const { return static_cast<std::size_t>(i * m + j); }
};

// The pixel whose ray meets the scene first within `search` (the lowest on a tie), -1 for none.
int firstContactPixel(const std::vector<RayHit>& hits, double search) {
  double first = std::numeric_limits<double>::infinity();
  int first_pixel = -1;
  for (std::size_t k = 0; k < hits.size(); ++k)
    if (hits[k].hit && hits[k].distance <= search && hits[k].distance < first) {
      first = hits[k].distance;
      first_pixel = static_cast<int>(k);
    }
  return first_pixel;
}

// The pressed pad's depth image: the pixels the pad reaches at its final travel on the object,
// their height along n above the waypoint (with the sensor's depth noise), and the other surfaces
// the pad reaches.
struct DepthImage {
  std::vector<char> on_object;
  std::vector<double> height;
  unsigned other_kinds{0};
};

// Adds the object's surface normals under the contact to *mean_contact_normal (normalised), when given.
DepthImage renderDepthImage(const PadPixels& pad, const std::vector<RayHit>& hits, const Eigen::Vector3d& waypoint,
                            double pressed, double depth_noise_m, std::normal_distribution<double>& gauss,
                            std::mt19937& rng, Eigen::Vector3d* mean_contact_normal) {
  const int m = pad.m;
  DepthImage image;
  image.on_object.assign(static_cast<std::size_t>(m * m), 0);
  image.height.assign(static_cast<std::size_t>(m * m), 0.0);
  for (int k = 0; k < m * m; ++k) {
    const RayHit& hit = hits[static_cast<std::size_t>(k)];
    if (!hit.hit || hit.distance > pressed) continue;
    if (hit.kind != SurfaceKind::kObject) {
      image.other_kinds |= static_cast<unsigned>(hit.kind);
      continue;
    }
    image.on_object[static_cast<std::size_t>(k)] = 1;
    if (mean_contact_normal) *mean_contact_normal += hit.normal;
    image.height[static_cast<std::size_t>(k)] =
        (hit.point - waypoint).dot(pad.n) + (depth_noise_m > 0.0 ? depth_noise_m * gauss(rng) : 0.0);
  }
  if (mean_contact_normal && !mean_contact_normal->isZero()) mean_contact_normal->normalize();
  return image;
}

// The contact points and normals a depth image gives, with the sensor's normal noise (a tilt of
// sd tilt_sigma rad), drawn in the order the points are read.
class PatchReader {
 public:
  PatchReader(const PadPixels& pad, const DepthImage& image, const Eigen::Vector3d& waypoint, double tilt_sigma,
              std::normal_distribution<double>& gauss, std::mt19937& rng)
      : pad_(pad), image_(image), waypoint_(waypoint), tilt_sigma_(tilt_sigma), gauss_(gauss), rng_(rng) {}

  bool contactAt(int i, int j) const { return image_.on_object[pad_.index(i, j)] != 0; }

  // The reported points: in each block of block x block pixels, its contact pixel nearest the
  // block's centre (a grazing contact of a few pixels still gives its points).
  std::vector<gpatlas_core::Contact> patch(int block) {
    const int m = pad_.m;
    std::vector<gpatlas_core::Contact> points;
    for (int bi = 0; bi < m; bi += block)
      for (int bj = 0; bj < m; bj += block) {
        const double ci = bi + 0.5 * (std::min(m, bi + block) - bi) - 0.5, cj = bj + 0.5 * (std::min(m, bj + block) - bj) - 0.5;
        int best_i = -1, best_j = -1;
        double best = std::numeric_limits<double>::infinity();
        for (int i = bi; i < std::min(m, bi + block); ++i)
          for (int j = bj; j < std::min(m, bj + block); ++j) {
            const double dist = (i - ci) * (i - ci) + (j - cj) * (j - cj);
            if (contactAt(i, j) && dist < best) {
              best = dist;
              best_i = i;
              best_j = j;
            }
          }
        if (best_i >= 0) points.push_back(contactOf(best_i, best_j));
      }
    return points;
  }

  gpatlas_core::Contact contactOf(int i, int j) {
    const Eigen::Vector3d &u = pad_.u, &v = pad_.v, &n = pad_.n;
    gpatlas_core::Contact contact;
    const double a = pad_.coordinate(i), b = pad_.coordinate(j);
    contact.position = waypoint_ + a * u + b * v + image_.height[pad_.index(i, j)] * n;
    double h_a = 0.0, h_b = 0.0;
    if (slope(i, j, true, &h_a) && slope(i, j, false, &h_b)) {
      // The height field's normal, (u + h_a n) x (v + h_b n).
      Eigen::Vector3d normal = (n - h_a * u - h_b * v).normalized();
      if (tilt_sigma_ > 0.0) {
        const Eigen::Vector3d t1 = normal.unitOrthogonal(), t2 = normal.cross(t1);
        normal = (normal + tilt_sigma_ * (gauss_(rng_) * t1 + gauss_(rng_) * t2)).normalized();
      }
      contact.normal = normal;
    } else {
      contact.normal = Eigen::Vector3d::Zero();
    }
    return contact;
  }

 private:
  // The surface's slope across the pad: central differences of the height where both neighbours
  // are in contact, one-sided where one is; a pixel with no neighbour in contact along an axis
  // has no measurable normal (reported as zero: the model then takes the point alone).
  bool slope(int i, int j, bool along_a, double* out) const {
    const int m = pad_.m;
    const double pitch = pad_.pitch;
    const auto h = [&](int ii, int jj) { return image_.height[pad_.index(ii, jj)]; };
    const int pi = along_a ? i - 1 : i, pj = along_a ? j : j - 1, ni = along_a ? i + 1 : i, nj = along_a ? j : j + 1;
    const bool has_prev = pi >= 0 && pj >= 0 && contactAt(pi, pj);
    const bool has_next = ni < m && nj < m && contactAt(ni, nj);
    if (has_prev && has_next) *out = (h(ni, nj) - h(pi, pj)) / (2.0 * pitch);
    else if (has_next) *out = (h(ni, nj) - h(i, j)) / pitch;
    else if (has_prev) *out = (h(i, j) - h(pi, pj)) / pitch;
    else return false;
    return true;
  }

  const PadPixels& pad_;
  const DepthImage& image_;
  const Eigen::Vector3d& waypoint_;
  const double tilt_sigma_;
  std::normal_distribution<double>& gauss_;
  std::mt19937& rng_;
};

// Free space over the pressed pad (at travel `pressed` from the pixels' origins `from`), on a grid
// of free_space_spacing_m, where nothing lies within the margin in front of it.
void appendFreeSpaceOverPad(const PadPixels& pad, const std::vector<RayHit>& hits, const Eigen::Matrix3Xd& from,
                            double pressed, const PatchProbeConfig& c, std::vector<Eigen::Vector3d>& free_space) {
  const int m = pad.m;
  const int free_block = std::max(1, static_cast<int>(std::lround(c.free_space_spacing_m / pad.pitch)));
  // A free-space spacing wider than the pad still gives the pad's centre.
  const int free_first = std::min(free_block, m) / 2;
  for (int i = free_first; i < m; i += free_block)
    for (int j = free_first; j < m; j += free_block) {
      const RayHit& hit = hits[static_cast<std::size_t>(i * m + j)];
      if (hit.hit && hit.distance < pressed + c.free_space_margin_m) continue;
      free_space.push_back(from.col(i * m + j) - pressed * pad.n);
    }
}

}  // namespace

ProbeStroke PatchProbe::press(const Scene& scene, const Eigen::Vector3d& waypoint, const Eigen::Vector3d& n,
                              const PressOptions& options) {
  ProbeStroke result;
  const Config& c = config_;
  const PadPixels pad(n, c.pad_size_m, c.resolution_m);
  const int m = pad.m;
  const double d = options.start_offset_m;
  const Eigen::Vector3d start = waypoint + d * n;
  // A pad that starts in contact has no meaningful first contact, and a real sensor could not
  // have got there. The sphere encloses the pad, curved or flat.
  if (const unsigned start_overlap = options.check_start ? scene.sphereOverlaps(padBoundingRadius(), start) : 0u) {
    result.failure = "pad start position overlaps the " + kindsToText(start_overlap);
    return result;
  }
  // One ray per pixel along -n from the pad's start: its length is the pad's travel when that
  // pixel meets the scene. The pad seeks its first contact over 2 d, as the other probes do; the
  // rays reach further, to the pressed pad and the free-space margin in front of it.
  const double search = 2.0 * d;
  const double reach = search + c.indentation_m + c.free_space_margin_m;
  Eigen::Matrix3Xd from(3, m * m), to(3, m * m);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      const double a = pad.coordinate(i), b = pad.coordinate(j);
      const Eigen::Vector3d origin = waypoint + (d + padRecess(std::hypot(a, b))) * n + a * pad.u + b * pad.v;
      from.col(i * m + j) = origin;
      to.col(i * m + j) = origin - reach * n;
    }
  const std::vector<RayHit> hits = scene.castRays(from, to);
  const int first_pixel = firstContactPixel(hits, search);
  if (first_pixel < 0) {
    // Nothing within the search; something just beyond it still keeps the margin.
    double nearest = search + c.free_space_margin_m;
    for (const RayHit& hit : hits)
      if (hit.hit) nearest = std::min(nearest, hit.distance);
    appendSamples(start, -n, nearest - c.free_space_margin_m, c.free_space_spacing_m, result.free_space);
    return result;
  }
  const double first = hits[static_cast<std::size_t>(first_pixel)].distance;
  if (options.first_travel_m) *options.first_travel_m = first;
  appendSamples(start, -n, first - c.free_space_margin_m, c.free_space_spacing_m, result.free_space);

  // Pressed: the pixels the pad reaches at its final travel are in contact.
  const double pressed = first + c.indentation_m;
  std::normal_distribution<double> gauss(0.0, 1.0);
  const DepthImage image =
      renderDepthImage(pad, hits, waypoint, pressed, c.depth_noise_m, gauss, rng_, options.mean_contact_normal);
  PatchReader reader(pad, image, waypoint, c.normal_noise_deg * kPi / 180.0, gauss, rng_);
  const int block = c.point_spacing_m > 0.0 ? std::max(1, static_cast<int>(std::lround(c.point_spacing_m / pad.pitch))) : 1;
  result.patch = reader.patch(block);
  const int first_i = first_pixel / m, first_j = first_pixel % m;
  if (!result.patch.empty()) {
    result.touched = SurfaceKind::kObject;
    // The first pixel to touch, if it touched the object; else the patch's first point.
    result.contact = reader.contactAt(first_i, first_j) ? reader.contactOf(first_i, first_j) : result.patch.front();
  } else {
    result.touched = hits[static_cast<std::size_t>(first_pixel)].kind;
  }
  if (image.other_kinds != 0)
    result.note = result.patch.empty()
                      ? "the pressed pad reached only the " + kindsToText(image.other_kinds)
                      : "the pressed pad also reached the " + kindsToText(image.other_kinds) +
                            " (indentation_m deeper than the object stands above it there)";

  gpatlas_core::PadPress pad_press;
  pad_press.centre = waypoint + (d - pressed) * n;
  Eigen::Matrix3d axes;
  axes << pad.u, pad.v, n;
  pad_press.orientation = Eigen::Quaterniond(axes);
  pad_press.size_m = c.pad_size_m;
  result.pad.push_back(pad_press);
  appendFreeSpaceOverPad(pad, hits, from, pressed, c, result.free_space);
  return result;
}

// ================================================================ factory

std::vector<std::string> probeModelNames() { return {"ray", "sphere", "patch"}; }

std::unique_ptr<ProbeModel> makeProbeModel(const std::string& name,
                                           const ProbeModelConfig& config) {
  if (name == "ray") return std::make_unique<RayProbe>(config.ray);
  if (name == "sphere") return std::make_unique<SphereProbe>(config.sphere);
  if (name == "patch") return std::make_unique<PatchProbe>(config.patch);
  throw std::runtime_error("unknown probe model '" + name + "' (known: ray, sphere, patch)");
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

int countPathContacts(const Scene& scene, const gpatlas_motion::ProbeGeometry& body,
                      const std::vector<Eigen::Vector3d>& tip_path, const Eigen::Vector3d& direction, double step_m,
                      unsigned* kinds) {
  const Eigen::Vector3d d = direction.normalized();
  const auto collides = [&](const Eigen::Vector3d& tip) {
    Capsule shaft;
    shaft.a = tip - body.tip_radius_m * d;
    shaft.b = tip - (body.tip_radius_m + body.shaft_length_m) * d;
    shaft.radius = body.shaft_radius_m;
    const unsigned met = scene.sphereOverlaps(body.tip_radius_m, tip) | scene.capsuleOverlaps({shaft}).front();
    if (kinds) *kinds |= met;
    return met != 0;
  };
  const auto steps = [step_m](const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
    return static_cast<int>(std::ceil((to - from).norm() / step_m));
  };
  return countContactRuns(tip_path, steps, collides);
}

int countArmPathContacts(const Scene& scene, const Arm& arm, const gpatlas_motion::ProbeGeometry& body,
                         const std::vector<Eigen::VectorXd>& joint_path, double step_m, unsigned* kinds) {
  const auto collides = [&](const Eigen::VectorXd& q) {
    unsigned met = armCollisions(arm, scene, q);
    const Eigen::Isometry3d tip = arm.forwardKinematics(q);
    countPathContacts(scene, body, {tip.translation()}, tip.linear().col(2), step_m, &met);
    if (kinds) *kinds |= met;
    return met != 0;
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
      countArmPathContacts(*scene_, *arm_, config_.body, approach, config_.motion_check_step_m, &last_way_kinds_);
  result->retreat_collisions =
      countArmPathContacts(*scene_, *arm_, config_.body, retreat, config_.motion_check_step_m, &last_way_kinds_);
  last_arm_solutions_ = approach;
  last_arm_solutions_.insert(last_arm_solutions_.end(), at_waypoints.begin(), at_waypoints.end());
  last_arm_solutions_.insert(last_arm_solutions_.end(), retreat.begin(), retreat.end());
  return "";
}

gpatlas_core::ProbeResult SimulatedProber::probe(const gpatlas_core::Touch& touch) {
  gpatlas_core::ProbeResult result;
  last_arm_solutions_.clear();
  last_way_kinds_ = 0;
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
                                                   config_.motion_check_step_m, &last_way_kinds_);
    result.retreat_collisions = countPathContacts(*scene_, config_.body, retreat, -last.normal,
                                                  config_.motion_check_step_m, &last_way_kinds_);
  }

  unsigned other_surfaces = 0;
  std::string stroke_failure;
  for (const ProbeAttempt& attempt : attempts) {
    ProbeStroke stroke = model_->stroke(*scene_, attempt.point, attempt.normal);
    if (!stroke.failure.empty()) stroke_failure = stroke.failure;
    result.free_space.insert(result.free_space.end(), stroke.free_space.begin(),
                             stroke.free_space.end());
    if (stroke.touched == SurfaceKind::kObject) {
      if (stroke.patch.empty()) result.contacts.push_back(stroke.contact);
      else result.contacts.insert(result.contacts.end(), stroke.patch.begin(), stroke.patch.end());
      result.pads.insert(result.pads.end(), stroke.pad.begin(), stroke.pad.end());
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
