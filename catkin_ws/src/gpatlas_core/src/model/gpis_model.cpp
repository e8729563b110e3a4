#include "gpatlas_core/model/gpis_model.h"

#include "gpatlas_core/common/dense_solve.h"
#include "gpatlas_core/model/gp_numerics.h"
#include "gpatlas_core/model/observation_screen.h"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace gpatlas_core {

double gpisTarget(const TrainingPoint& p, double scale) {
  if (std::isfinite(p.target_override)) return p.target_override;
  if (observesSlope(p)) return 1.0;
  if (p.label != PointLabel::kSurface && std::isfinite(p.surface_distance_m) && scale > 0.0)
    return static_cast<double>(static_cast<int>(p.label)) * std::min(1.0, std::max(0.0, p.surface_distance_m) / scale);
  return static_cast<double>(static_cast<int>(p.label));
}

namespace {

// Covariance between two observations at normalised positions a and b: of f itself where the
// direction is zero, else of f's slope along that unit direction. With d = a - b and k' = dk/dr:
//   cov(f(a), f(b))         = k(r)
//   cov(D_u f(a), f(b))     = (k'/r) d.u
//   cov(D_u f(a), D_v f(b)) = -(k'' - k'/r) (d.u)(d.v) / r^2 - (k'/r) u.v
// (the derivatives of k(|a - b|) in a and b); k'/r tends to k''(0) as r -> 0.
double observationCovariance(const Kernel& kernel, const Vector3& a, const Vector3& u, const Vector3& b,
                             const Vector3& v) {
  const Vector3 d = a - b;
  const double r = d.norm();
  const bool slope_a = u.squaredNorm() > 0.0, slope_b = v.squaredNorm() > 0.0;
  if (!slope_a && !slope_b) return kernel.value(r);
  const double slope_over_r = r > 0.0 ? kernel.derivative(r) / r : kernel.secondDerivative(0.0);
  if (!slope_b) return slope_over_r * d.dot(u);
  if (!slope_a) return -slope_over_r * d.dot(v);
  if (!(r > 0.0)) return -slope_over_r * u.dot(v);
  const Vector3 along = d / r;
  return -(kernel.secondDerivative(r) - slope_over_r) * along.dot(u) * along.dot(v) - slope_over_r * u.dot(v);
}

// Gradient with respect to the query x of cov(f(x), D_u f(b)) = -(k'/r) e.u, e = x - b:
// -(k'' - k'/r) (e^.u) e^ - (k'/r) u, with e^ = e / r.
Vector3 slopeCovarianceGradient(const Kernel& kernel, const Vector3& x, const Vector3& b, const Vector3& u) {
  const Vector3 e = x - b;
  const double r = e.norm();
  if (!(r > 0.0)) return -kernel.secondDerivative(0.0) * u;
  const double slope_over_r = kernel.derivative(r) / r;
  const Vector3 along = e / r;
  return -(kernel.secondDerivative(r) - slope_over_r) * along.dot(u) * along - slope_over_r * u;
}

}  // namespace

struct GpisModel::Impl {
  Impl() = default;
  Impl(Impl&&) = default;
  Impl& operator=(Impl&&) = default;
  // Deep copy (the kernel is cloned); the one place that lists the members. The copy holds
  // the n training rows without the original's spare capacity: copies are mostly snapshots
  // that never grow, and the factor's capacity grows with the square of the size. A copy that
  // is made to be extended asks for its room up front (capacity, in rows), so that the factor
  // is copied once.
  Impl(const Impl& o) : Impl(o, 0) {}
  Impl(const Impl& o, Eigen::Index capacity)
      : config(o.config),
        kernel(o.kernel ? o.kernel->clone() : nullptr),
        noise_scale(o.noise_scale),
        observations(o.observations),
        fitted(o.fitted),
        frame_preset(o.frame_preset),
        centroid(o.centroid),
        scale(o.scale),
        n(o.n),
        num_pseudo(o.num_pseudo),
        slope_rows(o.slope_rows),
        alpha(o.alpha),
        jitter(o.jitter) {
    const Eigen::Index cap = std::max(n, capacity);
    x.resize(3, cap);
    slope_dir.resize(3, cap);
    y.resize(cap);
    noise_var.resize(cap);
    chol.resize(cap, cap);
    x.leftCols(n) = o.x.leftCols(n);
    slope_dir.leftCols(n) = o.slope_dir.leftCols(n);
    y.head(n) = o.y.head(n);
    noise_var.head(n) = o.noise_var.head(n);
    chol.topLeftCorner(n, n) = o.chol.topLeftCorner(n, n);
  }

  Config config;
  std::unique_ptr<Kernel> kernel;
  double noise_scale{1.0};

  std::vector<TrainingPoint> observations;  // world frame, accepted points only

  // Derived state, rebuilt from `observations` whenever the normalisation changes.
  bool fitted{false};
  bool frame_preset{false};  // fitInFrame: the next refit keeps centroid/scale
  Vector3 centroid{Vector3::Zero()};
  double scale{1.0};
  Eigen::Index n{0};              // training-set size (pseudo-points first)
  Eigen::Index num_pseudo{0};
  Points3 x;                      // normalised inputs, capacity columns
  Points3 slope_dir;              // unit direction of a slope observation, zero for a value
  std::vector<Eigen::Index> slope_rows;  // the rows that observe a slope, ascending
  Eigen::VectorXd y;              // targets, capacity
  Eigen::VectorXd noise_var;      // per-point noise variance before noise_scale, capacity
  Eigen::MatrixXd chol;           // lower Cholesky factor in the top-left n x n block
  Eigen::VectorXd alpha;          // K^-1 y (size n)
  double jitter{0.0};

  void reserve(Eigen::Index needed) {
    const Eigen::Index cap = chol.rows();
    if (needed <= cap) return;
    const Eigen::Index new_cap = std::max<Eigen::Index>(needed + 64, cap + cap / 2);
    Eigen::MatrixXd new_chol(new_cap, new_cap);
    new_chol.topLeftCorner(n, n) = chol.topLeftCorner(n, n);
    chol.swap(new_chol);
    Points3 new_x(3, new_cap);
    new_x.leftCols(n) = x.leftCols(n);
    x.swap(new_x);
    Points3 new_dir(3, new_cap);
    new_dir.leftCols(n) = slope_dir.leftCols(n);
    slope_dir.swap(new_dir);
    Eigen::VectorXd new_y(new_cap), new_noise(new_cap);
    new_y.head(n) = y.head(n);
    new_noise.head(n) = noise_var.head(n);
    y.swap(new_y);
    noise_var.swap(new_noise);
  }

  Vector3 normalise(const Vector3& p) const { return (p - centroid) / scale; }

  bool isSlopeRow(Eigen::Index i) const { return slope_dir.col(i).squaredNorm() > 0.0; }
  void collectSlopeRows() {
    slope_rows.clear();
    for (Eigen::Index i = 0; i < n; ++i)
      if (isSlopeRow(i)) slope_rows.push_back(i);
  }

  // Removes training row r: the factor of K without row and column r is L11 and L31 as they
  // are, and below them the factor of L33 L33^T + l l^T (l: column r below the diagonal), a
  // rank-one update in O((n - r)^2). slope_rows must be collected again after it.
  void removeRow(Eigen::Index r) {
    const Eigen::Index tail = n - r - 1;
    Eigen::VectorXd l = chol.block(r + 1, r, tail, 1);
    auto lower = chol.block(r + 1, r + 1, tail, tail);
    for (Eigen::Index k = 0; k < tail; ++k) {
      const double diagonal = std::hypot(lower(k, k), l[k]);
      const double c = diagonal / lower(k, k), s = l[k] / lower(k, k);
      lower(k, k) = diagonal;
      const Eigen::Index below = tail - k - 1;
      if (below == 0) continue;
      lower.col(k).tail(below) = (lower.col(k).tail(below) + s * l.tail(below)) / c;
      l.tail(below) = c * l.tail(below) - s * lower.col(k).tail(below);
    }
    chol.block(r, 0, tail, r) = chol.block(r + 1, 0, tail, r).eval();
    chol.block(r, r, tail, tail) = chol.block(r + 1, r + 1, tail, tail).eval();
    x.middleCols(r, tail) = x.middleCols(r + 1, tail).eval();
    slope_dir.middleCols(r, tail) = slope_dir.middleCols(r + 1, tail).eval();
    y.segment(r, tail) = y.segment(r + 1, tail).eval();
    noise_var.segment(r, tail) = noise_var.segment(r + 1, tail).eval();
    --n;
  }
  // Prior covariance of training rows i != j.
  double covariance(Eigen::Index i, Eigen::Index j) const {
    return observationCovariance(*kernel, x.col(i), slope_dir.col(i), x.col(j), slope_dir.col(j));
  }
  double diagonal(Eigen::Index i) const {
    // A slope's prior variance is -k''(0): the curvature of the correlation at the origin.
    const double prior = isSlopeRow(i) ? -kernel->secondDerivative(0.0) : kernel->value(0.0);
    return prior + noise_scale * noise_var[i] * noiseUnit(*kernel) + jitter;
  }

  double varianceUnitFactor() const { return config.reference_prior_variance / kernel->value(0.0); }
  // Factor turning a noise variance given in reported units into units of f (the inverse of
  // varianceUnitFactor), so that the noise-to-prior ratio does not depend on the kernel's scale.
  double noiseUnit(const Kernel& k) const {
    return config.noise_in_reported_units ? k.value(0.0) / config.reference_prior_variance : 1.0;
  }

  void solveAlpha() {
    alpha = y.head(n);
    solveLowerInPlace(chol, n, alpha);
    solveLowerInPlace(chol, n, alpha, /*transposed=*/true);
  }

  // Factorises K for the first n points with the jitter ladder (CholeskyConfig). Returns false
  // when even the largest jitter fails.
  bool factorise(std::string* message) {
    jitter = 0.0;
    auto block = chol.topLeftCorner(n, n);
    for (Eigen::Index j = 0; j < n; ++j) {
      for (Eigen::Index i = j + 1; i < n; ++i) block(i, j) = covariance(i, j);
      block(j, j) = diagonal(j);
    }
    const double used = factoriseWithJitter(block, kernel->value(0.0), config.cholesky);
    if (used >= 0.0) {
      jitter = used;
      return true;
    }
    std::ostringstream msg;
    msg << "covariance matrix of " << n << " points is not positive definite even with jitter "
        << config.cholesky.jitter_max_relative << " of the prior variance (duplicate or contradictory points, or a "
        << "kernel outside its valid range)";
    *message = msg.str();
    return false;
  }

  // The frame of a refit: the current one, or with `renormalise` the surface points' centroid and
  // a scale that puts them within data_radius. False when the surface points coincide.
  bool refitFrame(bool renormalise, Vector3* centroid, double* scale) const;

  // Starts the training rows over with the pseudo-points of the current frame: outside points on
  // the domain sphere and, when it is surely inside, one inside point at the centroid. Returns
  // their count.
  Eigen::Index placePseudoPoints();

  // Observations that become training rows, and those dropped by cause.
  struct ObservationRows {
    std::vector<TrainingPoint> kept;
    std::vector<Vector3> x;         // normalised positions of `kept`
    std::vector<double> targets;    // of `kept`
    std::size_t out_of_domain{0}, duplicates{0}, bad_target{0};
  };
  // Appends the observations to the rows after the first num_pseudo: outside points beyond the
  // domain, non-finite targets and duplicates are dropped.
  ObservationRows appendObservationRows(Eigen::Index num_pseudo);
  // The points that would extend the current rows: the same tests, duplicates also against the
  // rows held. Nothing is changed.
  ObservationRows screenNewRows(const std::vector<TrainingPoint>& points) const;
  // Extends the factor by the rows (block Cholesky); false, with n and the factor as they were,
  // when the new block does not factorise with the current jitter.
  bool extendFactor(const ObservationRows& rows);

  // addPoints() takes these by a refit, not by extending the factor: a surface point beyond
  // renormalise_radius (the frame must grow) ...
  bool movesFrame(const std::vector<TrainingPoint>& points) const {
    for (const auto& p : points)
      if (isSurfaceValue(p) && normalise(p.position).norm() > config.renormalise_radius) return true;
    return false;
  }
  // ... or a contact or free-space point near the centroid, which invalidates the inside
  // pseudo-point there (refit() drops it when such a point is that close, e.g. in a cup's cavity).
  bool dropsInsidePoint(const ObservationRows& rows) const {
    const bool has_inside_point = num_pseudo > static_cast<Eigen::Index>(config.num_outside_points);
    if (!has_inside_point || !(config.inside_point_min_clearance > 0.0)) return false;
    for (std::size_t j = 0; j < rows.kept.size(); ++j)
      if (rows.kept[j].label != PointLabel::kInside && rows.x[j].norm() < config.inside_point_min_clearance) return true;
    return false;
  }
};

bool GpisModel::Impl::refitFrame(bool renormalise, Vector3* centroid, double* scale) const {
  *centroid = this->centroid;
  *scale = this->scale;
  if (!renormalise) return true;
  std::size_t num_surface = 0;
  Vector3 sum = Vector3::Zero();
  for (const auto& p : observations) {
    if (isSurfaceValue(p)) {
      ++num_surface;
      sum += p.position;
    }
  }
  *centroid = sum / static_cast<double>(num_surface);
  double max_dist = 0.0;
  for (const auto& p : observations)
    if (isSurfaceValue(p)) max_dist = std::max(max_dist, (p.position - *centroid).norm());
  if (!(max_dist > 1e-9)) return false;
  *scale = max_dist / config.data_radius;
  return true;
}

Eigen::Index GpisModel::Impl::placePseudoPoints() {
  const Config& c = config;
  const std::vector<Vector3> outside = fibonacciSphere(c.num_outside_points);
  // The inside point goes at the centroid only when that is surely inside the object: no
  // surface or free-space observation within inside_point_min_clearance (normalised) of it. The
  // centroid of a partial view of a cup or bowl lies in its cavity, a few centimetres from the
  // wall, where the camera saw free space; a -1 there tells the model the air is material.
  bool use_inside_point = c.inside_point_at_centroid;
  if (use_inside_point && c.inside_point_min_clearance > 0.0) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& p : observations)
      if (p.label != PointLabel::kInside) nearest = std::min(nearest, ((p.position - centroid) / scale).norm());
    use_inside_point = nearest >= c.inside_point_min_clearance;
  }
  const Eigen::Index pseudo = static_cast<Eigen::Index>(outside.size()) + (use_inside_point ? 1 : 0);
  n = 0;
  num_pseudo = pseudo;
  chol.resize(0, 0);
  x.resize(3, 0);
  slope_dir.resize(3, 0);
  y.resize(0);
  noise_var.resize(0);
  reserve(pseudo + static_cast<Eigen::Index>(observations.size()));

  const double pseudo_var = c.pseudo_point_sigma * c.pseudo_point_sigma;
  for (const auto& dir : outside) {
    x.col(n) = dir * c.domain_radius;
    slope_dir.col(n).setZero();
    y[n] = 1.0;
    noise_var[n] = pseudo_var;
    ++n;
  }
  if (use_inside_point) {
    x.col(n).setZero();
    slope_dir.col(n).setZero();
    y[n] = -1.0;
    noise_var[n] = pseudo_var;
    ++n;
  }
  return pseudo;
}

GpisModel::Impl::ObservationRows GpisModel::Impl::appendObservationRows(Eigen::Index pseudo) {
  const Config& c = config;
  ObservationRows rows;
  std::vector<TrainingPoint>& kept = rows.kept;
  kept.reserve(observations.size());
  const double dup2 = c.duplicate_distance * c.duplicate_distance;
  for (const auto& p : observations) {
    const Vector3 xn = normalise(p.position);
    if (xn.norm() > c.domain_radius) {
      ++rows.out_of_domain;
      continue;
    }
    const double target = gpisTarget(p, scale);
    if (!std::isfinite(target)) {
      ++rows.bad_target;
      continue;
    }
    // Duplicates: the same label's value (or the same slope) at (nearly) the same place; kept
    // observations are in the order of x after the pseudo-points.
    bool duplicate = false;
    const double value = target;
    for (std::size_t j = 0; j < kept.size() && !duplicate; ++j)
      duplicate = rows.targets[j] == value && sameSlopeDirection(kept[j], p) &&
                  (x.col(pseudo + static_cast<Eigen::Index>(j)) - xn).squaredNorm() <= dup2;
    if (duplicate) {
      ++rows.duplicates;
      continue;
    }
    rows.targets.push_back(value);
    x.col(n) = xn;
    slope_dir.col(n) = p.slope_direction;
    y[n] = target;
    noise_var[n] = p.noise_sigma * p.noise_sigma;
    ++n;
    kept.push_back(p);
  }
  return rows;
}

GpisModel::Impl::ObservationRows GpisModel::Impl::screenNewRows(const std::vector<TrainingPoint>& points) const {
  const Config& c = config;
  ObservationRows rows;
  std::vector<double> observation_values;
  observation_values.reserve(observations.size());
  for (const auto& o : observations) observation_values.push_back(gpisTarget(o, scale));
  const double dup2 = c.duplicate_distance * c.duplicate_distance;
  for (const auto& p : points) {
    const Vector3 xn = normalise(p.position);
    if (xn.norm() > c.domain_radius) {
      ++rows.out_of_domain;
      continue;
    }
    const double residual = gpisTarget(p, scale);
    if (!std::isfinite(residual)) {
      ++rows.bad_target;
      continue;
    }
    const double value = gpisTarget(p, scale);
    bool duplicate = false;
    for (std::size_t j = 0; j < observations.size() && !duplicate; ++j)
      duplicate = observation_values[j] == value && sameSlopeDirection(observations[j], p) &&
                  (x.col(num_pseudo + static_cast<Eigen::Index>(j)) - xn).squaredNorm() <= dup2;
    for (std::size_t j = 0; j < rows.kept.size() && !duplicate; ++j)
      duplicate = rows.targets[j] == value && sameSlopeDirection(rows.kept[j], p) &&
                  (rows.x[j] - xn).squaredNorm() <= dup2;
    if (duplicate) {
      ++rows.duplicates;
      continue;
    }
    rows.targets.push_back(residual);
    rows.kept.push_back(p);
    rows.x.push_back(xn);
  }
  return rows;
}

bool GpisModel::Impl::extendFactor(const ObservationRows& rows) {
  const Eigen::Index old_n = n;
  const Eigen::Index k = static_cast<Eigen::Index>(rows.kept.size());
  reserve(old_n + k);
  for (Eigen::Index j = 0; j < k; ++j) {
    x.col(old_n + j) = rows.x[static_cast<std::size_t>(j)];
    slope_dir.col(old_n + j) = rows.kept[static_cast<std::size_t>(j)].slope_direction;
    y[old_n + j] = rows.targets[static_cast<std::size_t>(j)];
    const double s = rows.kept[static_cast<std::size_t>(j)].noise_sigma;
    noise_var[old_n + j] = s * s;
  }
  // Block Cholesky extension: [L11 0; L21 L22] with L21^T = L11^-1 K12 and
  // L22 L22^T = K22 - L21 L21^T. Cost O(n^2 k) for the triangular solve.
  Eigen::MatrixXd cross(old_n, k);
  for (Eigen::Index j = 0; j < k; ++j)
    for (Eigen::Index i = 0; i < old_n; ++i) cross(i, j) = covariance(i, old_n + j);
  solveLowerInPlace(chol, old_n, cross);
  Eigen::MatrixXd schur(k, k);
  for (Eigen::Index j = 0; j < k; ++j) {
    for (Eigen::Index i = j + 1; i < k; ++i) schur(i, j) = covariance(old_n + i, old_n + j);
    schur(j, j) = diagonal(old_n + j);
  }
  schur.triangularView<Eigen::Lower>() -= cross.transpose() * cross;
  if (!choleskyWellConditioned(schur, kernel->value(0.0), config.cholesky)) return false;
  chol.block(old_n, 0, k, old_n) = cross.transpose();
  chol.block(old_n, old_n, k, k) = schur.triangularView<Eigen::Lower>();
  n = old_n + k;
  return true;
}

GpisModel::GpisModel(Config config) : impl_(std::make_unique<Impl>()) {
  impl_->config = std::move(config);
  impl_->kernel = makeKernel(impl_->config.kernel);
  if (!impl_->config.initial_params.empty()) {
    impl_->kernel->setLogParams(Eigen::Map<const Eigen::VectorXd>(impl_->config.initial_params.data(),
                                                                   impl_->config.initial_params.size()));
  }
  impl_->noise_scale = impl_->config.noise_scale;
  const Config& c = impl_->config;
  if (!(c.data_radius > 0.0 && c.data_radius < c.renormalise_radius && c.renormalise_radius <= c.domain_radius))
    throw std::invalid_argument("GpisModel: need 0 < data_radius < renormalise_radius <= domain_radius");
  if (2.0 * c.domain_radius > impl_->kernel->maxValidDistance())
    throw std::invalid_argument("GpisModel: kernel '" + c.kernel + "' is valid only up to distance " +
                                std::to_string(impl_->kernel->maxValidDistance()) +
                                " but the domain diameter is " + std::to_string(2.0 * c.domain_radius));
  if (!(c.noise_scale > 0.0)) throw std::invalid_argument("GpisModel: noise_scale must be > 0");
}

GpisModel::GpisModel(const GpisModel& other) = default;

GpisModel::GpisModel(const GpisModel& other, std::size_t room_for_observations)
    : SurfaceModel(other),
      impl_(std::make_unique<Impl>(*other.impl_,
                                   other.impl_->num_pseudo + static_cast<Eigen::Index>(room_for_observations))) {}

GpisModel& GpisModel::operator=(const GpisModel& other) = default;
GpisModel::GpisModel(GpisModel&&) noexcept = default;
GpisModel& GpisModel::operator=(GpisModel&&) noexcept = default;
GpisModel::~GpisModel() = default;

namespace {

// Slope directions are made unit: the covariance of a slope observation (observationCovariance)
// is that of the slope along a unit direction.
const ObservationScreenOptions kScreenOptions{/*normalise_slope_directions=*/true};

}  // namespace

FitReport GpisModel::fit(const std::vector<TrainingPoint>& points) { return fitFrom(points, nullptr, 0.0); }

FitReport GpisModel::fitInFrame(const std::vector<TrainingPoint>& points, const Vector3& centroid, double scale) {
  FitReport report;
  if (!checkFrame(centroid, scale, &report)) return report;
  return fitFrom(points, &centroid, scale);
}

FitReport GpisModel::fitFrom(const std::vector<TrainingPoint>& points, const Vector3* centroid, double scale) {
  FitReport report;
  std::vector<TrainingPoint> accepted = screenObservations(points, kScreenOptions, &report);
  if (centroid && report.num_rejected == 0) {
    FitReport updated;
    if (updateInFrame(accepted, *centroid, scale, &updated)) return updated;
  }
  // A full fit starts from an empty set: the existing observations are replaced.
  Impl trial;
  trial.config = impl_->config;
  trial.kernel = impl_->kernel->clone();
  trial.noise_scale = impl_->noise_scale;
  trial.observations = std::move(accepted);
  if (centroid) {
    trial.centroid = *centroid;
    trial.scale = scale;
    trial.frame_preset = true;
  }
  std::swap(*impl_, trial);  // `trial` now holds the previous state
  report.num_added = impl_->observations.size();
  FitReport fit_report = refit();
  fit_report.warnings.insert(fit_report.warnings.begin(), report.warnings.begin(), report.warnings.end());
  fit_report.num_rejected += report.num_rejected;
  if (!fit_report.ok) {
    std::swap(*impl_, trial);  // restore
    return fit_report;
  }
  return fit_report;
}

bool GpisModel::updateInFrame(const std::vector<TrainingPoint>& points, const Vector3& centroid, double scale,
                              FitReport* report) {
  Impl& m = *impl_;
  if (!m.fitted || m.centroid != centroid || m.scale != scale) return false;
  // The points held, in order, some missing (removed) or with another target, then new ones. A
  // refit's factor of what is held depends on the points' positions, slopes, noise and labels,
  // and on which of them are duplicates, which compares their targets.
  const auto samePoint = [](const TrainingPoint& p, const TrainingPoint& o) {
    return p.position == o.position && p.label == o.label && p.noise_sigma == o.noise_sigma &&
           p.slope_direction == o.slope_direction;
  };
  const std::size_t held = m.observations.size();
  std::vector<std::size_t> removed;  // in what is held
  std::vector<std::size_t> changed;  // in points
  std::size_t kept = 0;              // points[0, kept) are the held points that stay
  for (std::size_t j = 0; j < held; ++j) {
    if (kept < points.size() && samePoint(points[kept], m.observations[j])) {
      if (gpisTarget(points[kept], m.scale) != gpisTarget(m.observations[j], m.scale)) changed.push_back(kept);
      ++kept;
    } else {
      removed.push_back(j);
    }
  }
  // Each removal is a rank-one update of up to n^2: beyond a third of the points a refit is cheaper
  // (a moved point early in the list removes everything after it here).
  if (3 * removed.size() > held) return false;
  // Without the inside pseudo-point, the refit might place it once a point near the centroid is
  // gone (inside points do not count).
  const bool has_inside_point = m.num_pseudo > static_cast<Eigen::Index>(m.config.num_outside_points);
  for (const std::size_t j : removed)
    if (!has_inside_point && m.config.inside_point_at_centroid && m.observations[j].label != PointLabel::kInside)
      return false;
  const double dup2 = m.config.duplicate_distance * m.config.duplicate_distance * m.scale * m.scale;
  for (const std::size_t i : changed) {
    if (!std::isfinite(gpisTarget(points[i], m.scale))) return false;
    const double value = gpisTarget(points[i], m.scale);
    for (std::size_t k = 0; k < kept; ++k)
      if (k != i && gpisTarget(points[k], m.scale) == value && sameSlopeDirection(points[k], points[i]) &&
          (points[k].position - points[i].position).squaredNorm() <= dup2)
        return false;
  }
  // Removing rows cannot be undone in place: keep the state until the update has succeeded.
  std::optional<Impl> backup;
  if (!removed.empty()) backup.emplace(m);
  const std::vector<TrainingPoint> previous = m.observations;
  std::vector<std::pair<Eigen::Index, double>> previous_residuals;
  for (auto j = removed.rbegin(); j != removed.rend(); ++j) m.removeRow(m.num_pseudo + static_cast<Eigen::Index>(*j));
  if (!removed.empty()) m.collectSlopeRows();
  for (const std::size_t i : changed) {
    double& y = m.y[m.num_pseudo + static_cast<Eigen::Index>(i)];
    previous_residuals.emplace_back(m.num_pseudo + static_cast<Eigen::Index>(i), y);
    y = gpisTarget(points[i], m.scale);
  }
  m.observations.assign(points.begin(), points.begin() + static_cast<std::ptrdiff_t>(kept));
  m.solveAlpha();
  const std::vector<TrainingPoint> appended(points.begin() + static_cast<std::ptrdiff_t>(kept), points.end());
  *report = appended.empty() ? FitReport() : addPoints(appended);
  if (appended.empty()) {
    report->ok = true;
    report->jitter = m.jitter;
  }
  if (!report->ok) {
    if (backup) {
      m = std::move(*backup);
    } else {
      for (const auto& [row, y] : previous_residuals) m.y[row] = y;
      m.observations = previous;
      m.solveAlpha();
    }
    return false;
  }
  report->num_added = m.observations.size();
  report->message = "refitted by update: " + std::to_string(removed.size()) + " point(s) removed, " +
                    std::to_string(changed.size()) + " target(s) changed, " + std::to_string(appended.size()) +
                    " point(s) appended" + (report->message.empty() ? "" : " (" + report->message + ")");
  return true;
}

FitReport GpisModel::refit(bool renormalise) {
  FitReport report;
  report.full_refit = true;
  Impl& m = *impl_;
  const Config& c = m.config;

  std::size_t num_surface = 0;
  for (const auto& p : m.observations)
    if (isSurfaceValue(p)) ++num_surface;
  if (num_surface < 4) {
    report.message = "need at least 4 valid surface points to fit, got " + std::to_string(num_surface);
    return report;
  }
  if ((m.fitted || m.frame_preset) && !renormalise) {
    for (const auto& p : m.observations)
      if (isSurfaceValue(p) && m.normalise(p.position).norm() > c.renormalise_radius) renormalise = true;
  }
  renormalise = renormalise || !(m.fitted || m.frame_preset);
  m.frame_preset = false;
  Vector3 centroid;
  double scale = 0.0;
  if (!m.refitFrame(renormalise, &centroid, &scale)) {
    report.message = "degenerate surface data: all surface points coincide";
    return report;
  }
  report.renormalised = renormalise;

  // Keep the old state so that a failed factorisation leaves the model untouched.
  Impl backup(m);
  m.centroid = centroid;
  m.scale = scale;
  const Eigen::Index num_pseudo = m.placePseudoPoints();
  Impl::ObservationRows rows = m.appendObservationRows(num_pseudo);
  if (rows.out_of_domain > 0)
    report.warnings.push_back(std::to_string(rows.out_of_domain) + " outside point(s) beyond the model domain dropped");
  if (rows.duplicates > 0) report.warnings.push_back(std::to_string(rows.duplicates) + " duplicate point(s) dropped");
  if (rows.bad_target > 0) {
    // Never drop accepted data silently: refuse the fit instead.
    m = std::move(backup);
    report.message = "the target is not finite at " + std::to_string(rows.bad_target) + " observation(s)";
    return report;
  }
  report.num_rejected = rows.out_of_domain + rows.duplicates;
  m.observations = std::move(rows.kept);
  m.collectSlopeRows();

  std::string error;
  if (!m.factorise(&error)) {
    m = std::move(backup);
    report.message = error;
    return report;
  }
  if (m.jitter > c.cholesky.jitter_first_relative * m.kernel->value(0.0))
    report.warnings.push_back("covariance needed jitter " + std::to_string(m.jitter) + " to factorise");
  m.solveAlpha();
  m.fitted = true;
  report.ok = true;
  report.jitter = m.jitter;
  report.num_added = m.observations.size();
  report.message = "fitted " + std::to_string(m.n) + " training points (" + std::to_string(num_pseudo) +
                   " pseudo-points)";
  return report;
}

FitReport GpisModel::refitWith(const std::vector<TrainingPoint>& added, bool renormalise) {
  Impl& m = *impl_;
  const auto previous = m.observations;
  m.observations.insert(m.observations.end(), added.begin(), added.end());
  FitReport report = refit(renormalise);
  if (!report.ok) m.observations = previous;
  report.num_added = report.ok ? added.size() : 0;
  return report;
}

FitReport GpisModel::addPoints(const std::vector<TrainingPoint>& points) {
  if (!isFitted()) return fit(points);
  FitReport report;
  std::vector<TrainingPoint> accepted = screenObservations(points, kScreenOptions, &report);
  Impl& m = *impl_;
  if (accepted.empty()) {
    report.ok = true;
    report.message = "no valid point to add";
    return report;
  }

  // A surface point far from the current centroid means the object is larger than the data
  // seen so far: renormalise so that every point, old and new, stays within the domain.
  if (m.movesFrame(accepted)) {
    FitReport refit_report = refitWith(accepted, true);
    refit_report.warnings.insert(refit_report.warnings.begin(), report.warnings.begin(), report.warnings.end());
    if (refit_report.ok) refit_report.message = "renormalised and refitted: " + refit_report.message;
    return refit_report;
  }

  // Screen against the domain and duplicates in the current frame.
  const Impl::ObservationRows rows = m.screenNewRows(accepted);
  if (rows.out_of_domain > 0)
    report.warnings.push_back(std::to_string(rows.out_of_domain) + " outside point(s) beyond the model domain dropped");
  if (rows.duplicates > 0) report.warnings.push_back(std::to_string(rows.duplicates) + " duplicate point(s) dropped");
  if (rows.bad_target > 0)
    report.warnings.push_back(std::to_string(rows.bad_target) + " point(s) dropped: their target is not finite");
  report.num_rejected += rows.out_of_domain + rows.duplicates + rows.bad_target;
  const std::vector<TrainingPoint>& kept = rows.kept;
  if (kept.empty()) {
    report.ok = true;
    report.message = "no new point to add";
    return report;
  }

  // Where extending the factor would not give the model a refit builds, the points go in by a
  // full refit of all the data; on failure the observations are restored.
  const auto refitWithKept = [&]() {
    FitReport refit_report = refitWith(kept, false);
    refit_report.num_rejected += report.num_rejected;
    refit_report.warnings.insert(refit_report.warnings.begin(), report.warnings.begin(), report.warnings.end());
    return refit_report;
  };

  if (m.dropsInsidePoint(rows)) return refitWithKept();

  const Eigen::Index k = static_cast<Eigen::Index>(kept.size());
  if (!m.extendFactor(rows)) {
    // The new block needs more jitter than the model has: a full refit escalates the jitter on
    // every point alike (a larger jitter on the new block only would not be what a refit builds).
    FitReport refit_report = refitWithKept();
    if (!refit_report.ok)
      refit_report.message = "adding " + std::to_string(k) +
                             " point(s) makes the covariance singular (a point contradicts existing data); model "
                             "unchanged: " +
                             refit_report.message;
    return refit_report;
  }
  m.observations.insert(m.observations.end(), kept.begin(), kept.end());
  m.collectSlopeRows();
  m.solveAlpha();
  report.ok = true;
  report.num_added = kept.size();
  report.jitter = m.jitter;
  report.message = "added " + std::to_string(k) + " point(s) incrementally";
  return report;
}

bool GpisModel::isFitted() const { return impl_->fitted; }
const GpisModel::Config& GpisModel::config() const { return impl_->config; }
const std::vector<TrainingPoint>& GpisModel::observations() const { return impl_->observations; }
std::size_t GpisModel::size() const { return static_cast<std::size_t>(impl_->n); }
ModelFrame GpisModel::frame() const {
  const Impl& m = *impl_;
  ModelFrame f;
  f.centroid = m.centroid;
  f.scale = m.scale;
  f.domain_radius_m = m.config.domain_radius * m.scale;
  f.data_radius_m = m.config.data_radius * m.scale;
  // A raw posterior variance times this is in the reported units.
  f.variance_unit_factor = m.varianceUnitFactor();
  return f;
}
Vector3 GpisModel::toNormalised(const Vector3& x_world) const { return impl_->normalise(x_world); }
Vector3 GpisModel::toWorld(const Vector3& x_normalised) const { return impl_->centroid + impl_->scale * x_normalised; }

std::unique_ptr<SurfaceModel> GpisModel::clone() const { return std::make_unique<GpisModel>(*this); }

std::vector<std::string> GpisModel::hyperparameterNames() const {
  std::vector<std::string> names;
  for (const std::string& p : impl_->kernel->paramNames()) names.push_back("log_" + p);
  names.push_back("log_noise_scale");
  return names;
}

Eigen::VectorXd GpisModel::hyperparameters() const {
  const Eigen::VectorXd kernel_params = impl_->kernel->logParams();
  Eigen::VectorXd all(kernel_params.size() + 1);
  all << kernel_params, std::log(impl_->noise_scale);
  return all;
}

FitReport GpisModel::setHyperparameters(const Eigen::VectorXd& log_params) {
  const Eigen::Index k = impl_->kernel->numParams();
  if (log_params.size() != k + 1) {
    FitReport report;
    report.message = "expected " + std::to_string(k + 1) + " log-parameters (" + std::to_string(k) +
                     " of the kernel, then the noise scale), got " + std::to_string(log_params.size());
    return report;
  }
  return setHyperparameters(log_params.head(k), std::exp(log_params[k]));
}

FitReport GpisModel::restore(const SurfaceModelState& state) {
  FitReport report;
  const Eigen::Index k = impl_->kernel->numParams();
  if (!checkStateModel(state, &report)) return report;
  const Eigen::VectorXd params = Eigen::Map<const Eigen::VectorXd>(state.hyperparameters.data(),
                                                                    static_cast<Eigen::Index>(state.hyperparameters.size()));
  if (params.size() != k + 1 || !params.allFinite()) {
    report.message = "the state has " + std::to_string(params.size()) + " hyperparameters, the '" +
                     impl_->kernel->name() + "' GPIS has " + std::to_string(k + 1) + " (or they are not finite)";
    return report;
  }
  GpisModel trial(*this);
  trial.impl_->kernel->setLogParams(params.head(k));
  trial.impl_->noise_scale = std::exp(params[k]);
  report = trial.fitInFrame(state.observations, state.centroid, state.scale);
  if (report.ok) {
    *this = std::move(trial);
    setPositionSdScale(state.position_sd_scale);
  }
  return report;
}

const Kernel& GpisModel::kernel() const { return *impl_->kernel; }

BatchPrediction GpisModel::predictBatch(const Points3& x_world, bool with_gradient,
                                        bool with_variance_gradient, bool with_variance) const {
  const Impl& m = *impl_;
  if (!m.fitted) throw std::logic_error("GpisModel: query before the model was fitted");
  const Eigen::Index q = x_world.cols();
  const Eigen::Index n = m.n;
  BatchPrediction out(q, with_gradient, with_variance_gradient);
  if (q == 0) return out;

  Points3 xq = (x_world.colwise() - m.centroid) / m.scale;
  // The training inputs as three contiguous coordinate arrays, so that the distances and the
  // kernel for one query and all n training points are array operations.
  const Eigen::ArrayXd train_x = m.x.row(0).head(n).transpose().array();
  const Eigen::ArrayXd train_y = m.x.row(1).head(n).transpose().array();
  const Eigen::ArrayXd train_z = m.x.row(2).head(n).transpose().array();
  Eigen::ArrayXd dx(n), dy(n), dz(n);  // reused for every query: no allocation per query
  const auto distancesTo = [&](Eigen::Index j, Eigen::ArrayXd* distance) {
    dx = train_x - xq(0, j);
    dy = train_y - xq(1, j);
    dz = train_z - xq(2, j);
    *distance = (dx * dx + dy * dy + dz * dz).sqrt();
  };
  // Gradient of sum_i w_i k(|x - x_i|) at query j, given slope_i = (dk/dr / r)(|x - x_i|):
  // sum_i w_i slope_i (x - x_i), in world units.
  const double inv_scale = 1.0 / m.scale;
  const auto weightedGradient = [&](Eigen::Index j, const Eigen::ArrayXd& slope, const auto& weights) {
    Vector3 sum = Vector3::Zero();
    const Vector3 xj = xq.col(j);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double w = slope[i] * weights[i];
      sum.x() += w * (xj.x() - train_x[i]);
      sum.y() += w * (xj.y() - train_y[i]);
      sum.z() += w * (xj.z() - train_z[i]);
    }
    return Vector3(sum * inv_scale);
  };

  // The array code is written for rows that observe f's value; a row that observes a slope gets
  // its covariance and its gradient from observationCovariance and slopeCovarianceGradient.
  const Vector3 no_slope = Vector3::Zero();
  const auto gradientOf = [&](Eigen::Index j, Eigen::ArrayXd* slope, const auto& weights) {
    for (Eigen::Index i : m.slope_rows) (*slope)[i] = 0.0;
    Vector3 gradient = weightedGradient(j, *slope, weights);
    for (Eigen::Index i : m.slope_rows)
      gradient += weights[i] * inv_scale * slopeCovarianceGradient(*m.kernel, xq.col(j), m.x.col(i), m.slope_dir.col(i));
    return gradient;
  };
  Eigen::MatrixXd cross(n, q);  // cov(row i, f(x*_j))
  Eigen::ArrayXd distance, k, slope;
  for (Eigen::Index j = 0; j < q; ++j) {
    out.in_domain[j] = xq.col(j).allFinite() && xq.col(j).norm() <= m.config.domain_radius;
    distancesTo(j, &distance);
    m.kernel->values(distance, &k);
    cross.col(j) = k.matrix();
    for (Eigen::Index i : m.slope_rows)
      cross(i, j) = observationCovariance(*m.kernel, m.x.col(i), m.slope_dir.col(i), xq.col(j), no_slope);
    if (with_gradient) {
      m.kernel->derivativesOverDistance(distance, &slope);
      out.gradient.col(j) = gradientOf(j, &slope, m.alpha);
    }
  }
  out.mean.noalias() = cross.transpose() * m.alpha;

  if (!with_variance && !with_variance_gradient) {
    out.variance.setConstant(std::numeric_limits<double>::quiet_NaN());
    return out;
  }

  // v = L^-1 k*, var = k(0) - |v|^2; K^-1 k* = L^-T v is needed only for the variance gradient.
  Eigen::MatrixXd solved = cross;
  solveLowerInPlace(m.chol, n, solved);
  const double prior = m.kernel->value(0.0);
  const double unit = m.varianceUnitFactor();
  out.variance = ((prior - solved.colwise().squaredNorm().array()).max(0.0) * unit).matrix();
  if (with_variance_gradient) {
    solveLowerInPlace(m.chol, n, solved, /*transposed=*/true);
    // d/dx [k(0) - k*^T K^-1 k*] = -2 (dk*/dx)^T K^-1 k*; the slopes are recomputed rather than
    // kept for every query (an n x q matrix) from the loop above.
    for (Eigen::Index j = 0; j < q; ++j) {
      distancesTo(j, &distance);
      m.kernel->derivativesOverDistance(distance, &slope);
      out.variance_gradient.col(j) = -2.0 * unit * gradientOf(j, &slope, solved.col(j));
    }
  }
  return out;
}

Eigen::MatrixXd GpisModel::varianceAfter(const Points3& x_world,
                                         const std::vector<std::vector<TrainingPoint>>& touches) const {
  const Impl& m = *impl_;
  if (!m.fitted) throw std::logic_error("GpisModel: query before the model was fitted");
  const Eigen::Index q = x_world.cols(), n = m.n;
  // The rows each batch would add by extending the factor; `by_refit`: the batches addPoints()
  // takes by a refit, whose variance the clone's way gives.
  std::vector<Impl::ObservationRows> rows(touches.size());
  std::vector<std::size_t> by_refit;
  std::vector<std::pair<std::size_t, std::size_t>> columns;  // (batch, row) of each extra column
  for (std::size_t b = 0; b < touches.size(); ++b) {
    FitReport screen;
    const std::vector<TrainingPoint> accepted = screenObservations(touches[b], kScreenOptions, &screen);
    bool refits = m.movesFrame(accepted);
    if (!refits) rows[b] = m.screenNewRows(accepted);
    refits = refits || m.dropsInsidePoint(rows[b]);
    if (refits) {
      by_refit.push_back(b);
      rows[b] = {};
    }
    for (std::size_t j = 0; j < rows[b].kept.size(); ++j) columns.emplace_back(b, j);
  }
  const Eigen::Index extra = static_cast<Eigen::Index>(columns.size());
  const Points3 xq = (x_world.colwise() - m.centroid) / m.scale;
  const Vector3 no_slope = Vector3::Zero();
  const auto rowDirection = [&](std::size_t b, std::size_t j) {
    const Vector3& u = rows[b].kept[j].slope_direction;
    return u.squaredNorm() > 0.0 ? Vector3(u.normalized()) : no_slope;
  };
  // cov(training row i, reference j) and cov(training row i, new row e), then L^-1 of both.
  Eigen::MatrixXd solved(n, q + extra);
  tbb::parallel_for(Eigen::Index{0}, q + extra, [&](Eigen::Index col) {
    Vector3 point = col < q ? Vector3(xq.col(col)) : rows[columns[col - q].first].x[columns[col - q].second];
    const Vector3 direction = col < q ? no_slope : rowDirection(columns[col - q].first, columns[col - q].second);
    for (Eigen::Index i = 0; i < n; ++i)
      solved(i, col) = observationCovariance(*m.kernel, m.x.col(i), m.slope_dir.col(i), point, direction);
  });
  constexpr Eigen::Index kChunk = 64;
  tbb::parallel_for(Eigen::Index{0}, (q + extra + kChunk - 1) / kChunk, [&](Eigen::Index block) {
    const Eigen::Index begin = block * kChunk, count = std::min(q + extra, begin + kChunk) - begin;
    solveLowerInPlace(m.chol, n, solved.middleCols(begin, count));
  });
  const double prior = m.kernel->value(0.0), unit = m.varianceUnitFactor();
  const Eigen::ArrayXd before = (prior - solved.leftCols(q).colwise().squaredNorm().array()).max(0.0);
  Eigen::MatrixXd after(q, static_cast<Eigen::Index>(touches.size()));
  Eigen::Index first = q;
  for (std::size_t b = 0; b < touches.size(); ++b) {
    const Eigen::Index k = static_cast<Eigen::Index>(rows[b].kept.size());
    if (k == 0) {
      after.col(static_cast<Eigen::Index>(b)) = before.matrix() * unit;
      continue;
    }
    const auto v_new = solved.middleCols(first, k);
    // S = prior covariance of the new rows (with their noise and the factor's jitter, as
    // extendFactor builds them) minus what the data explain; C = cov(new rows, references).
    Eigen::MatrixXd schur(k, k), cross(k, q);
    for (Eigen::Index a = 0; a < k; ++a) {
      const std::size_t ja = static_cast<std::size_t>(a);
      const Vector3 ua = rowDirection(b, ja);
      for (Eigen::Index d = 0; d < k; ++d)
        schur(a, d) = observationCovariance(*m.kernel, rows[b].x[ja], ua, rows[b].x[static_cast<std::size_t>(d)],
                                            rowDirection(b, static_cast<std::size_t>(d)));
      const double sigma = rows[b].kept[ja].noise_sigma;
      schur(a, a) += m.noise_scale * sigma * sigma * m.noiseUnit(*m.kernel) + m.jitter;
      for (Eigen::Index j = 0; j < q; ++j)
        cross(a, j) = observationCovariance(*m.kernel, rows[b].x[ja], ua, xq.col(j), no_slope);
    }
    schur.noalias() -= v_new.transpose() * v_new;
    cross.noalias() -= v_new.transpose() * solved.leftCols(q);
    Eigen::LLT<Eigen::MatrixXd> llt(schur);
    if (llt.info() != Eigen::Success) {
      by_refit.push_back(b);
    } else {
      llt.matrixL().solveInPlace(cross);
      after.col(static_cast<Eigen::Index>(b)) = ((before - cross.colwise().squaredNorm().transpose().array()).max(0.0) * unit).matrix();
    }
    first += k;
  }
  if (!by_refit.empty()) {
    std::vector<std::vector<TrainingPoint>> refitted;
    for (std::size_t b : by_refit) refitted.push_back(touches[b]);
    const Eigen::MatrixXd cloned = SurfaceModel::varianceAfter(x_world, refitted);
    for (std::size_t i = 0; i < by_refit.size(); ++i)
      after.col(static_cast<Eigen::Index>(by_refit[i])) = cloned.col(static_cast<Eigen::Index>(i));
  }
  return after;
}


double GpisModel::logMarginalLikelihood() const {
  const Impl& m = *impl_;
  if (!m.fitted) return std::numeric_limits<double>::quiet_NaN();
  return gpatlas_core::logMarginalLikelihood(m.chol.topLeftCorner(m.n, m.n), m.y.head(m.n), m.alpha);
}

FitReport GpisModel::setHyperparameters(const Eigen::VectorXd& kernel_log_params, double noise_scale) {
  FitReport report;
  if (!kernel_log_params.allFinite() || kernel_log_params.size() != impl_->kernel->numParams() ||
      !(noise_scale > 0.0) || !std::isfinite(noise_scale)) {
    report.message = "invalid hyperparameters (wrong count, NaN or non-positive noise scale)";
    return report;
  }
  std::unique_ptr<Kernel> trial = impl_->kernel->clone();
  trial->setLogParams(kernel_log_params);
  if (2.0 * impl_->config.domain_radius > trial->maxValidDistance()) {
    report.message = "kernel parameters make the kernel invalid over the model domain";
    return report;
  }
  std::unique_ptr<Kernel> previous = std::move(impl_->kernel);
  const double previous_noise = impl_->noise_scale;
  impl_->kernel = std::move(trial);
  impl_->noise_scale = noise_scale;
  if (!impl_->fitted) {
    report.ok = true;
    report.message = "hyperparameters set; model not fitted yet";
    return report;
  }
  report = refit();
  if (!report.ok) {
    // refit() already restored the previous factorisation; only the parameters remain.
    impl_->kernel = std::move(previous);
    impl_->noise_scale = previous_noise;
  }
  return report;
}

}  // namespace gpatlas_core
