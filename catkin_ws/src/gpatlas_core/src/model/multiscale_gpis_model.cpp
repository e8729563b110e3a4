#include "gpatlas_core/model/multiscale_gpis_model.h"

#include "gpatlas_core/model/gp_numerics.h"
#include "gpatlas_core/model/kernel.h"
#include "gpatlas_core/model/observation_screen.h"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

namespace gpatlas_core {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using CellKey = std::int64_t;

// Integer cell coordinates packed into one key (21 bits each: +-1e6 cells, 15 km at 15 mm).
CellKey packKey(const Eigen::Vector3i& c) {
  constexpr std::int64_t offset = 1 << 20;
  return ((static_cast<std::int64_t>(c.x()) + offset) << 42) | ((static_cast<std::int64_t>(c.y()) + offset) << 21) |
         (static_cast<std::int64_t>(c.z()) + offset);
}

bool isValueObservation(const TrainingPoint& p) { return !observesSlope(p); }

// Smooth bump of the blending weights, b(t) = (1 - t^2)^2 on |t| < 1, and its derivative.
double bump(double t) {
  const double u = 1.0 - t * t;
  return u > 0.0 ? u * u : 0.0;
}
double bumpDerivative(double t) {
  const double u = 1.0 - t * t;
  return u > 0.0 ? -4.0 * t * u : 0.0;
}

// Deterministic voxel thinning: the indices (into `points`, ascending) of at most `cap` of the
// `candidates` (ascending), one per voxel and label, the one nearest the voxel's centre (the
// lower index on a tie); none for a cap of 0. The voxel starts at the candidates' extent / 20
// and grows x1.25 until the count fits; the grid is anchored at the candidates' bounding box, so
// the choice depends on the data only.
std::vector<std::size_t> thinByVoxels(const std::vector<TrainingPoint>& points, const std::vector<std::size_t>& candidates,
                                      std::size_t cap) {
  if (candidates.size() <= cap) return candidates;
  if (cap == 0) return {};
  Vector3 lo = Vector3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (std::size_t i : candidates) {
    lo = lo.cwiseMin(points[i].position);
    hi = hi.cwiseMax(points[i].position);
  }
  const double extent = std::max((hi - lo).maxCoeff(), 1e-9);
  std::vector<std::size_t> kept;
  struct Best {
    std::size_t index;
    double distance2;
  };
  for (double voxel = extent / 20.0;; voxel *= 1.25) {
    std::unordered_map<std::uint64_t, Best> best;
    best.reserve(std::min(candidates.size(), 4 * cap));
    for (std::size_t i : candidates) {
      const Vector3 q = (points[i].position - lo) / voxel;
      const Eigen::Vector3i c(static_cast<int>(std::floor(q.x())), static_cast<int>(std::floor(q.y())),
                              static_cast<int>(std::floor(q.z())));
      const double d2 = (q - (c.cast<double>().array() + 0.5).matrix()).squaredNorm();
      // Voxel indices from the bounding box's corner are small and non-negative (at most ~21).
      const std::uint64_t key = (static_cast<std::uint64_t>(c.x()) << 42) | (static_cast<std::uint64_t>(c.y()) << 22) |
                                (static_cast<std::uint64_t>(c.z()) << 2) |
                                static_cast<std::uint64_t>(static_cast<int>(points[i].label) + 1);
      auto found = best.find(key);
      if (found == best.end()) best.emplace(key, Best{i, d2});
      else if (d2 < found->second.distance2) found->second = Best{i, d2};
    }
    kept.clear();
    for (const auto& entry : best) kept.push_back(entry.second.index);
    if (kept.size() <= cap || voxel > 2.0 * extent) break;
  }
  std::sort(kept.begin(), kept.end());
  return kept;
}

std::vector<std::size_t> mergeSorted(std::vector<std::size_t> a, const std::vector<std::size_t>& b) {
  a.insert(a.end(), b.begin(), b.end());
  std::sort(a.begin(), a.end());
  return a;
}

// The points are kept as the caller gave them, slope directions too: nothing here needs them unit
// (the coarse GpisModel makes its own copies' directions unit, the cells take no slopes), and
// observations() and state() report the caller's points.
const ObservationScreenOptions kScreenOptions{/*normalise_slope_directions=*/false};

struct FineParams {
  double sigma, length_m, noise_m;
  static FineParams fromLog(const Eigen::Vector3d& log_params) {
    return {std::exp(log_params[0]), std::exp(log_params[1]), std::exp(log_params[2])};
  }
  // The local kernel, in metres.
  Matern52Kernel kernel() const { return Matern52Kernel(sigma, length_m); }
};

// What a batch of queries asks for; `slope`: the kernel's derivative, for either gradient.
struct BatchNeeds {
  bool gradient, variance_gradient, variance, slope;
};

// A query's cells (at most 2 per axis, so 8), with their blending weights and gradients.
constexpr int kMaxSlots = 8;
struct Slot {
  std::size_t cell;
  double weight;
  Vector3 weight_gradient;
};
struct QuerySlots {
  std::vector<std::array<Slot, kMaxSlots>> slots;
  std::vector<int> count;
};

// Queries grouped by cell: cell c's (query * kMaxSlots + slot) entries are
// entries[offset[c] .. offset[c + 1]).
struct CellGroups {
  std::vector<std::size_t> offset, entries;
};

// Per (query * kMaxSlots + slot): the cell's residual mean and variance and their gradients.
struct CellPredictions {
  std::vector<double> mean, variance;
  std::vector<Vector3> gradient, variance_gradient;
};

// Queries grouped by cell, so that each cell's factor is used once per batch (a triangular
// solve with many right-hand sides instead of one per query).
CellGroups groupByCell(const QuerySlots& query_slots, std::size_t num_cells) {
  const std::size_t q = query_slots.count.size();
  CellGroups groups;
  std::vector<std::size_t>& offset = groups.offset;
  offset.assign(num_cells + 1, 0);
  for (std::size_t col = 0; col < q; ++col)
    for (int k = 0; k < query_slots.count[col]; ++k) ++offset[query_slots.slots[col][static_cast<std::size_t>(k)].cell + 1];
  for (std::size_t c = 0; c < num_cells; ++c) offset[c + 1] += offset[c];
  std::vector<std::size_t> fill(offset.begin(), offset.end() - 1);
  groups.entries.resize(offset.back());
  for (std::size_t col = 0; col < q; ++col)
    for (int k = 0; k < query_slots.count[col]; ++k)
      groups.entries[fill[query_slots.slots[col][static_cast<std::size_t>(k)].cell]++] =
          col * kMaxSlots + static_cast<std::size_t>(k);
  return groups;
}

// The coarse level at every query, in parallel chunks.
BatchPrediction coarseBatch(const GpisModel& coarse_model, const Points3& x_world, const BatchNeeds& needs) {
  const Eigen::Index q = x_world.cols();
  BatchPrediction coarse(q, needs.gradient, needs.variance_gradient);
  constexpr Eigen::Index chunk = 128;
  tbb::parallel_for(Eigen::Index{0}, (q + chunk - 1) / chunk, [&](Eigen::Index b) {
    const Eigen::Index begin = b * chunk, count = std::min(q, begin + chunk) - begin;
    const BatchPrediction part = coarse_model.predictBatch(x_world.middleCols(begin, count), needs.gradient,
                                                           needs.variance_gradient, needs.variance);
    coarse.mean.segment(begin, count) = part.mean;
    coarse.variance.segment(begin, count) = part.variance;
    coarse.in_domain.segment(begin, count) = part.in_domain;
    if (needs.gradient) coarse.gradient.middleCols(begin, count) = part.gradient;
    if (needs.variance_gradient) coarse.variance_gradient.middleCols(begin, count) = part.variance_gradient;
  });
  return coarse;
}

// Blend: r = sum w r_c / (sum w + w0), v = (sum w v_c + w0 sigma^2) / (sum w + w0), with their
// gradients by the quotient rule (the zero expert's weight is constant), added to the coarse
// level's mean and variance (the latter in reported units, x unit).
void blendLevels(const BatchPrediction& coarse, const QuerySlots& query_slots, const CellPredictions& cells,
                 const Matern52Kernel& kernel, double w0, double unit, const BatchNeeds& needs, BatchPrediction& out) {
  tbb::parallel_for(Eigen::Index{0}, coarse.mean.size(), [&](Eigen::Index col) {
    const std::size_t jq = static_cast<std::size_t>(col);
    double sum_w = w0, sum_wr = 0.0, sum_wv = w0 * kernel.value(0.0);
    Vector3 sum_gw = Vector3::Zero(), sum_g_wr = Vector3::Zero(), sum_g_wv = Vector3::Zero();
    for (int k = 0; k < query_slots.count[jq]; ++k) {
      const Slot& slot = query_slots.slots[jq][static_cast<std::size_t>(k)];
      const std::size_t e = jq * kMaxSlots + static_cast<std::size_t>(k);
      sum_w += slot.weight;
      sum_gw += slot.weight_gradient;
      sum_wr += slot.weight * cells.mean[e];
      if (needs.gradient) sum_g_wr += slot.weight_gradient * cells.mean[e] + slot.weight * cells.gradient[e];
      if (needs.variance) sum_wv += slot.weight * cells.variance[e];
      if (needs.variance_gradient)
        sum_g_wv += slot.weight_gradient * cells.variance[e] + slot.weight * cells.variance_gradient[e];
    }
    const double r = sum_wr / sum_w;
    out.mean[col] = coarse.mean[col] + r;
    out.in_domain[col] = coarse.in_domain[col];
    if (needs.gradient) out.gradient.col(col) = coarse.gradient.col(col) + (sum_g_wr - r * sum_gw) / sum_w;
    if (needs.variance) {
      const double v = sum_wv / sum_w;
      out.variance[col] = coarse.variance[col] + unit * v;
      if (needs.variance_gradient)
        out.variance_gradient.col(col) = coarse.variance_gradient.col(col) + unit * (sum_g_wv - v * sum_gw) / sum_w;
    } else {
      out.variance[col] = kNaN;
    }
  });
}

struct Cell {
  Eigen::Vector3i coords{Eigen::Vector3i::Zero()};
  Vector3 centre{Vector3::Zero()};
  std::vector<std::size_t> members;  // observation indices, ascending
  Points3 x;                         // member positions relative to the centre (metres)
  Eigen::VectorXd y;                 // residual targets gpisTarget - m0
  Eigen::MatrixXd chol;              // lower Cholesky factor of K + noise
  Eigen::VectorXd alpha;             // K^-1 y
  double jitter{0.0};
};

// Prior covariance of a cell's members (lower triangle) plus noise and jitter.
Eigen::MatrixXd cellCovariance(const Points3& x, const Matern52Kernel& kernel, double noise_var) {
  const Eigen::Index n = x.cols();
  Eigen::MatrixXd k(n, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::Index i = j + 1; i < n; ++i) k(i, j) = kernel.value((x.col(i) - x.col(j)).norm());
    k(j, j) = kernel.value(0.0) + noise_var;
  }
  return k;
}

// Factorises a cell's covariance with the jitter ladder.
bool factoriseCell(Cell* cell, const Matern52Kernel& kernel, double noise_var, const CholeskyConfig& cholesky) {
  Eigen::MatrixXd k = cellCovariance(cell->x, kernel, noise_var);
  const double jitter = factoriseWithJitter(k, kernel.value(0.0), cholesky);
  if (jitter < 0.0) return false;
  cell->chol = k.triangularView<Eigen::Lower>();
  cell->jitter = jitter;
  cell->alpha = solveWithFactor(cell->chol, cell->y);
  return true;
}

// Log marginal likelihood of one cell's targets and its gradient in (log sigma, log length,
// log noise); NaN when the covariance does not factorise without jitter.
double cellLogLikelihood(const Cell& cell, const FineParams& p, double scale, const CholeskyConfig& cholesky,
                         Eigen::Vector3d* gradient) {
  const Matern52Kernel kernel = p.kernel();
  const double noise_f = p.noise_m / scale;
  Eigen::MatrixXd k = cellCovariance(cell.x, kernel, noise_f * noise_f);
  if (!choleskyWellConditioned(k, kernel.value(0.0), cholesky)) return kNaN;
  const Eigen::VectorXd alpha = solveWithFactor(k, cell.y);
  if (gradient) {
    double d0[2];
    kernel.paramGradient(0.0, d0);
    *gradient = logMarginalLikelihoodGradient(k, alpha, 3, [&](Eigen::Index i, Eigen::Index j, double* d) {
      if (i == j) {
        d[0] = d0[0];
        d[1] = d0[1];
        d[2] = 2.0 * noise_f * noise_f;  // the noise variance's derivative in log noise
      } else {
        kernel.paramGradient((cell.x.col(i) - cell.x.col(j)).norm(), d);
        d[2] = 0.0;
      }
    });
  }
  return logMarginalLikelihood(k, cell.y, alpha);
}


}  // namespace

namespace {

// The coarse level after an update: extended, or refitted in its frame (`grows` false).
struct CoarseUpdate {
  GpisModel model;
  std::vector<std::size_t> selection;  // the observations it holds
  bool grows{false};
  FitReport report;
};

// The cells an update changes: those whose extended region holds a new value observation
// (`rebuilt_index`, refactored with their new members, then the new cells at new surface data,
// `created`), and the others (`resolved_index`), whose factor is kept and only the targets and
// weights follow the coarse level. `rebuilt` and `resolved` in the order of the indices.
struct CellUpdate {
  std::vector<std::size_t> rebuilt_index, resolved_index;
  std::vector<Cell> rebuilt, resolved;
  std::size_t created{0};
  FitReport report;
};

}  // namespace

struct MultiscaleGpisModel::Impl {
  Config config;
  GpisModelConfig coarse_config;
  GpisModel coarse;
  std::vector<std::size_t> coarse_members;   // observation indices the coarse model was given
  std::vector<TrainingPoint> observations;   // accepted, world frame
  Eigen::Vector3d log_fine{Eigen::Vector3d::Zero()};  // log sigma, log length_m, log noise_m
  // Value observations within the extended region of every cell key they fall in (whether or
  // not a cell exists there), ascending: what a new cell trains on.
  std::unordered_map<CellKey, std::vector<std::size_t>> buckets;
  std::unordered_map<CellKey, std::size_t> cell_index;
  std::vector<Cell> cells;
  bool fitted{false};
  TuneReport fine_tune;

  explicit Impl(Config c, GpisModelConfig cc) : config(std::move(c)), coarse_config(cc), coarse(std::move(cc)) {}

  double halfWidth() const { return 0.5 * config.cell_size_m + config.overlap_m; }
  double lengthMax() const { return config.overlap_m; }
  FineParams fine() const { return FineParams::fromLog(log_fine); }
  double noiseVar(const FineParams& p) const {
    const double noise_f = p.noise_m / coarse.scale();
    return noise_f * noise_f;
  }

  Eigen::Vector3d defaultLogFine() const {
    const auto clamp = [](double v, double lo, double hi) { return std::log(std::min(hi, std::max(lo, v))); };
    return Eigen::Vector3d(clamp(config.sigma, config.sigma_min, config.sigma_max),
                           clamp(config.length_m, config.length_min_m, lengthMax()),
                           clamp(config.noise_m, config.noise_min_m, config.noise_max_m));
  }

  // The observations the coarse model is given: the view's surface values and its free space
  // and interior (source vision, not the table beside the object), each thinned to its cap;
  // the probe's contacts (with their slopes) and its other values (approach free space, interior
  // behind contacts) greedily in the order they came, one per voxel of a fixed world grid, the
  // latter up to their cap. None of the probe's data changes which earlier points are kept, so
  // an exploration step extends the coarse factor instead of refitting it.
  std::vector<std::size_t> coarseSelection(const std::vector<TrainingPoint>& obs) const {
    std::vector<std::size_t> always, view_surface, view_other;
    std::unordered_set<CellKey> probe_voxels;
    std::unordered_map<CellKey, Vector3> contact_voxels;  // the kept contact of each voxel
    const double voxel = config.coarse_probe_voxel_m;
    const auto voxelOf = [voxel](const Vector3& x) {
      return packKey(Eigen::Vector3i((x / voxel).array().floor().cast<int>()));
    };
    for (std::size_t i = 0; i < obs.size(); ++i) {
      const TrainingPoint& p = obs[i];
      if (p.source == PointSource::kViewSupport) {
        // The table seen beside the object says where the object ends next to its data, which
        // is the cells' business. In the coarse level it would also shape the unseen side, whose
        // distance from the table the view does not give.
        continue;
      } else if (observesSlope(p)) {
        // A contact's slopes go where it goes.
        const auto kept = contact_voxels.find(voxelOf(p.position));
        if (fromView(p.source) || (kept != contact_voxels.end() && kept->second == p.position)) always.push_back(i);
      } else if (!fromView(p.source) && p.label == PointLabel::kSurface) {
        // A slide's contacts a few millimetres apart are detail for the cells, which take them
        // all; the coarse level, whose kernel spans the object, takes one per voxel.
        if (contact_voxels.emplace(voxelOf(p.position), p.position).second) always.push_back(i);
      } else if (!fromView(p.source)) {
        if (probe_voxels.size() >= config.coarse_max_probe_other_points) continue;
        if (probe_voxels.insert(voxelOf(p.position)).second) always.push_back(i);
      } else if (p.label == PointLabel::kSurface) {
        view_surface.push_back(i);
      } else if (!(p.surface_distance_m < config.overlap_m)) {
        // Free space and interior closer to the surface than the fine level's reach are detail
        // the coarse level cannot represent: left to the cells, they do not crowd out the far
        // free space, the interior and the table that shape the unseen parts.
        view_other.push_back(i);
      }
    }
    std::vector<std::size_t> selected = mergeSorted(always, thinByVoxels(obs, view_surface, config.coarse_max_surface_points));
    return mergeSorted(selected, thinByVoxels(obs, view_other, config.coarse_max_other_points));
  }

  // Keys of the cells whose extended region holds the point (at most 2 per axis).
  void cellsContaining(const Vector3& p, std::vector<Eigen::Vector3i>* out) const {
    out->clear();
    const double s = config.cell_size_m, h = halfWidth();
    std::array<std::array<int, 3>, 3> axis{};
    std::array<int, 3> count{};
    for (int d = 0; d < 3; ++d) {
      const int base = static_cast<int>(std::floor(p[d] / s));
      for (int c = base - 1; c <= base + 1; ++c)
        if (std::abs(p[d] - (c + 0.5) * s) <= h) axis[d][count[d]++] = c;
    }
    for (int a = 0; a < count[0]; ++a)
      for (int b = 0; b < count[1]; ++b)
        for (int c = 0; c < count[2]; ++c) out->emplace_back(axis[0][a], axis[1][b], axis[2][c]);
  }

  Eigen::Vector3i coreOf(const Vector3& p) const {
    const double s = config.cell_size_m;
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / s)), static_cast<int>(std::floor(p.y() / s)),
                           static_cast<int>(std::floor(p.z() / s)));
  }

  void addToBuckets(std::size_t first) {
    std::vector<Eigen::Vector3i> keys;
    for (std::size_t i = first; i < observations.size(); ++i) {
      if (!isValueObservation(observations[i])) continue;
      cellsContaining(observations[i].position, &keys);
      for (const Eigen::Vector3i& k : keys) buckets[packKey(k)].push_back(i);
    }
  }

  // Coarse means at the given observations, in parallel chunks.
  std::vector<double> coarseMeans(const std::vector<std::size_t>& indices) const {
    std::vector<double> means(indices.size());
    constexpr std::size_t chunk = 256;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (indices.size() + chunk - 1) / chunk),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t b = range.begin(); b != range.end(); ++b) {
                          const std::size_t begin = b * chunk, end = std::min(indices.size(), begin + chunk);
                          Points3 x(3, static_cast<Eigen::Index>(end - begin));
                          for (std::size_t i = begin; i < end; ++i)
                            x.col(static_cast<Eigen::Index>(i - begin)) = observations[indices[i]].position;
                          const Eigen::VectorXd m = coarse.predictBatch(x, false, false, false).mean;
                          for (std::size_t i = begin; i < end; ++i) means[i] = m[static_cast<Eigen::Index>(i - begin)];
                        }
                      });
    return means;
  }

  // Members and positions of a cell from its bucket (targets are set by setTargets).
  Cell makeCell(const Eigen::Vector3i& coords) const {
    Cell cell;
    cell.coords = coords;
    cell.centre = (coords.cast<double>().array() + 0.5).matrix() * config.cell_size_m;
    cell.members = thinByVoxels(observations, buckets.at(packKey(coords)),
                                static_cast<std::size_t>(std::max(1, config.max_points_per_cell)));
    cell.x.resize(3, static_cast<Eigen::Index>(cell.members.size()));
    for (std::size_t i = 0; i < cell.members.size(); ++i)
      cell.x.col(static_cast<Eigen::Index>(i)) = observations[cell.members[i]].position - cell.centre;
    return cell;
  }

  // Residual targets of every cell, from the coarse means at all their members.
  void setTargets(std::vector<Cell*> targets) const {
    std::vector<std::size_t> needed;
    for (const Cell* c : targets) needed.insert(needed.end(), c->members.begin(), c->members.end());
    std::sort(needed.begin(), needed.end());
    needed.erase(std::unique(needed.begin(), needed.end()), needed.end());
    const std::vector<double> means = coarseMeans(needed);
    std::unordered_map<std::size_t, double> m0;
    m0.reserve(needed.size());
    for (std::size_t i = 0; i < needed.size(); ++i) m0.emplace(needed[i], means[i]);
    const double s = coarse.scale();
    for (Cell* c : targets) {
      c->y.resize(static_cast<Eigen::Index>(c->members.size()));
      for (std::size_t i = 0; i < c->members.size(); ++i)
        c->y[static_cast<Eigen::Index>(i)] = gpisTarget(observations[c->members[i]], s) - m0.at(c->members[i]);
    }
  }

  // The cells the tuning and fineLogMarginalLikelihood use: the most populated (ties: by key).
  std::vector<std::size_t> tuningSample() const {
    std::vector<std::size_t> order(cells.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      if (cells[a].members.size() != cells[b].members.size()) return cells[a].members.size() > cells[b].members.size();
      return packKey(cells[a].coords) < packKey(cells[b].coords);
    });
    order.resize(std::min(order.size(), static_cast<std::size_t>(std::max(0, config.tune_max_cells))));
    return order;
  }

  double sampleLogLikelihood(const std::vector<std::size_t>& sample, const Eigen::Vector3d& log_params,
                             Eigen::Vector3d* gradient) const {
    const FineParams p = FineParams::fromLog(log_params);
    std::vector<double> values(sample.size());
    std::vector<Eigen::Vector3d> grads(sample.size());
    tbb::parallel_for(std::size_t{0}, sample.size(), [&](std::size_t i) {
      values[i] = cellLogLikelihood(cells[sample[i]], p, coarse.scale(), coarse_config.cholesky,
                                    gradient ? &grads[i] : nullptr);
    });
    double sum = 0.0;
    if (gradient) gradient->setZero();
    for (std::size_t i = 0; i < sample.size(); ++i) {
      sum += values[i];
      if (gradient) *gradient += grads[i];
    }
    return sum;
  }

  // Maximises the sample's summed log likelihood over the fine log-parameters (Ceres, bounded by
  // a sigmoid change of variables); keeps log_fine when it does not improve.
  TuneReport tuneFine();

  // Fits everything from `observations` (in the given frame when `frame_centroid` is set), with
  // the current coarse and fine hyperparameters (fine ones tuned first when `tune`). With
  // `coarse_from`, the coarse level starts as a copy of it, whose factor a refit that only drops
  // or retargets some of its points and appends others updates (GpisModel::updateInFrame).
  FitReport build(const Vector3* frame_centroid, double frame_scale, bool tune, const GpisModel* coarse_from = nullptr);
  // `trial` (a fresh Impl of the same configs) with these log-hyperparameters (the coarse GPIS's,
  // then the fine level's) and this model's last fine tuning; false with the reason in `report`.
  bool withHyperparameters(const Eigen::VectorXd& log_params, Impl* trial, FitReport* report) const;

  // A fit from scratch in the current frame of the observations and `added`; replaces this
  // model when it succeeds. `why` opens the message.
  FitReport refitWithAdded(const std::vector<TrainingPoint>& added, const FitReport& screen, const std::string& why);
  // The coarse level for all observations (the first old_count of which it holds now).
  CoarseUpdate updateCoarse(const std::vector<TrainingPoint>& all, std::size_t old_count) const;
  // The cells that `stage` (this model's index structures with the observations from old_count on
  // added) changes, refactored or re-solved; nothing is committed.
  CellUpdate updateCells(const Impl& stage, std::size_t old_count) const;
  // Takes the staged coarse level, observations and buckets and the updated cells.
  void commit(Impl&& stage, CellUpdate& update, const std::vector<std::size_t>& coarse_selection);

  // Each query's cells and blending weights.
  QuerySlots querySlots(const Points3& x_world) const;
  // The blending weight of the cell at `coords` at x (whether or not the cell exists).
  double cellWeight(const Eigen::Vector3i& coords, const Vector3& x) const;

  // ---- varianceAfter's pieces
  // Why addPoints() takes this point by a full refit, or nullptr: surface data from a view, or a
  // contact beyond the frame's radius.
  const char* refitReason(const TrainingPoint& p) const {
    if (!isSurfaceValue(p)) return nullptr;
    if (fromView(p.source)) return "new surface data from a view, refitted";
    if (((p.position - coarse.centroid()) / coarse.scale()).norm() > coarse_config.renormalise_radius)
      return "a contact beyond the frame's radius, renormalised and refitted";
    return nullptr;
  }
  // Whether the coarse level can be extended to `selection` (coarseSelection of the observations
  // with new ones from old_count on): it keeps every point it holds and adds only new ones
  // (`extra`); else it is refitted in its frame.
  bool extendsCoarse(const std::vector<std::size_t>& selection, std::size_t old_count,
                     std::vector<std::size_t>* extra) const {
    std::set_difference(selection.begin(), selection.end(), coarse_members.begin(), coarse_members.end(),
                        std::back_inserter(*extra));
    return std::includes(selection.begin(), selection.end(), coarse_members.begin(), coarse_members.end()) &&
           (extra->empty() || extra->front() >= old_count);
  }
  // The points of each batch that addPoints() would give the coarse level; `by_refit` set for
  // the batches it would take by a refit.
  std::vector<std::vector<TrainingPoint>> coarseShares(const std::vector<std::vector<TrainingPoint>>& accepted,
                                                       std::vector<char>* by_refit) const;
  // A batch's value points by the existing cell whose region holds them, and the cells its
  // surface values would create (with the batch's points in their regions).
  struct NewCell {
    Eigen::Vector3i coords;
    std::vector<Vector3> points;
  };
  struct FantasyCells {
    std::unordered_map<std::size_t, std::vector<Vector3>> existing;
    std::vector<NewCell> created;
  };
  FantasyCells fantasyCells(const std::vector<TrainingPoint>& accepted) const;
  // Cell c's variance at its queries (per query and slot, in `variance`) after it takes `points`;
  // `solved_queries`: L^-1 k(X_c, x) for those queries, in the order of `groups`.
  void lowerCellVariance(std::size_t c, const std::vector<Vector3>& points, const Eigen::MatrixXd& solved_queries,
                         const Points3& x_world, const CellGroups& groups, std::vector<double>* variance) const;
  std::vector<Cell> buildFantasyCells(const std::vector<NewCell>& created) const;
  // predictBatch's blend of the fine variance at x: its cells' (`slot_variance` per slot) and
  // the cells `built`, where their weight reaches.
  double blendedFineVariance(const Vector3& x, const std::array<Slot, kMaxSlots>& slots, int count,
                             const double* slot_variance, const std::vector<Cell>& built) const;
  // Each cell's residual mean and variance (and gradients) at the queries that fall in it.
  CellPredictions predictCells(const Points3& x_world, const CellGroups& groups, const Matern52Kernel& kernel,
                               const BatchNeeds& needs) const;

  FitReport factorCells(std::vector<Cell*> targets) const {
    FitReport report;
    const FineParams p = fine();
    const Matern52Kernel kernel(p.sigma, p.length_m);
    const double noise_var = noiseVar(p);
    std::vector<char> ok(targets.size(), 0);
    tbb::parallel_for(std::size_t{0}, targets.size(),
                      [&](std::size_t i) { ok[i] = factoriseCell(targets[i], kernel, noise_var, coarse_config.cholesky) ? 1 : 0; });
    std::size_t failed = 0, jittered = 0;
    for (std::size_t i = 0; i < targets.size(); ++i) {
      failed += ok[i] ? 0 : 1;
      jittered += targets[i]->jitter > 0.0 ? 1 : 0;
    }
    if (failed > 0) {
      report.message = std::to_string(failed) + " local GP cell(s) could not be factorised even with jitter";
      return report;
    }
    if (jittered > 0) report.warnings.push_back(std::to_string(jittered) + " cell(s) needed a diagonal jitter");
    report.ok = true;
    return report;
  }
};

TuneReport MultiscaleGpisModel::Impl::tuneFine() {
  TuneReport report;
  const auto start = std::chrono::steady_clock::now();
  const std::vector<std::size_t> sample = tuningSample();
  report.params_before = log_fine.array().exp();
  report.params_after = report.params_before;
  if (sample.empty()) {
    report.message = "fine tuning skipped: no cell";
    return report;
  }
  report.log_likelihood_before = sampleLogLikelihood(sample, log_fine, nullptr);
  const Eigen::Vector3d lower(std::log(config.sigma_min), std::log(config.length_min_m), std::log(config.noise_min_m));
  const Eigen::Vector3d upper(std::log(config.sigma_max), std::log(lengthMax()), std::log(config.noise_max_m));
  const BoundedObjective objective = [&](const Eigen::VectorXd& theta, Eigen::VectorXd* gradient) {
    Eigen::Vector3d grad;
    const double lml = sampleLogLikelihood(sample, theta, gradient ? &grad : nullptr);
    if (gradient) *gradient = grad;
    return lml;
  };
  const BoundedMaximum best = maximiseBounded(objective, log_fine, lower, upper, config.tune_max_iterations);
  report.iterations = best.iterations;
  const Eigen::Vector3d tuned = best.x;
  const double after = best.value;
  std::ostringstream msg;
  if (std::isfinite(after) && after > report.log_likelihood_before) {
    log_fine = tuned;
    report.ok = true;
    msg << "fine level tuned on " << sample.size() << " cell(s): log likelihood " << report.log_likelihood_before
        << " -> " << after << " in " << report.iterations << " iterations; sigma " << std::exp(tuned[0])
        << ", length " << std::exp(tuned[1]) * 1e3 << " mm, noise " << std::exp(tuned[2]) * 1e3 << " mm";
    report.log_likelihood_after = after;
  } else {
    msg << "fine tuning did not improve the log likelihood (" << best.message << "); defaults kept";
    report.log_likelihood_after = report.log_likelihood_before;
  }
  report.message = msg.str();
  report.params_after = log_fine.array().exp();
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

bool MultiscaleGpisModel::Impl::withHyperparameters(const Eigen::VectorXd& log_params, Impl* trial,
                                                    FitReport* report) const {
  const Eigen::Index nc = coarse.hyperparameters().size();
  if (log_params.size() != nc + 3 || !log_params.allFinite()) {
    report->message = "expected " + std::to_string(nc + 3) + " finite log-parameters (" + std::to_string(nc) +
                      " of the coarse GPIS, then fine sigma, length_m, noise_m), got " + std::to_string(log_params.size());
    return false;
  }
  *report = trial->coarse.setHyperparameters(log_params.head(nc));
  if (!report->ok) return false;
  trial->log_fine = log_params.tail(3);
  trial->fine_tune = fine_tune;
  return true;
}

FitReport MultiscaleGpisModel::Impl::build(const Vector3* frame_centroid, double frame_scale, bool tune,
                                           const GpisModel* coarse_from) {
  coarse_members = coarseSelection(observations);
  std::vector<TrainingPoint> coarse_points;
  coarse_points.reserve(coarse_members.size());
  for (std::size_t i : coarse_members) coarse_points.push_back(observations[i]);
  if (coarse_from) coarse = GpisModel(*coarse_from, coarse_points.size());
  FitReport report = frame_centroid ? coarse.fitInFrame(coarse_points, *frame_centroid, frame_scale)
                                    : coarse.fit(coarse_points);
  report.full_refit = true;
  if (!report.ok) {
    report.message = "coarse GPIS: " + report.message;
    return report;
  }
  const std::string coarse_message = report.message;

  buckets.clear();
  addToBuckets(0);
  cells.clear();
  cell_index.clear();
  std::vector<Eigen::Vector3i> coords;
  for (const TrainingPoint& p : observations)
    if (isSurfaceValue(p)) {
      const CellKey k = packKey(coreOf(p.position));
      if (cell_index.emplace(k, 0).second) coords.push_back(coreOf(p.position));
    }
  std::sort(coords.begin(), coords.end(),
            [](const Eigen::Vector3i& a, const Eigen::Vector3i& b) { return packKey(a) < packKey(b); });
  cells.resize(coords.size());
  tbb::parallel_for(std::size_t{0}, coords.size(), [&](std::size_t i) { cells[i] = makeCell(coords[i]); });
  for (std::size_t i = 0; i < cells.size(); ++i) cell_index[packKey(cells[i].coords)] = i;
  std::vector<Cell*> all;
  for (Cell& c : cells) all.push_back(&c);
  setTargets(all);

  if (tune) {
    log_fine = defaultLogFine();
    fine_tune = tuneFine();
    (fine_tune.ok ? report.notes : report.warnings).push_back(fine_tune.message);
  }
  FitReport fine_report = factorCells(all);
  report.warnings.insert(report.warnings.end(), fine_report.warnings.begin(), fine_report.warnings.end());
  if (!fine_report.ok) {
    report.ok = false;
    report.message = fine_report.message;
    return report;
  }
  std::size_t total = 0;
  for (const Cell& c : cells) total += c.members.size();
  std::ostringstream msg;
  msg << "coarse: " << coarse_message << " (" << coarse_members.size() << " of " << observations.size()
      << " observations); fine: " << cells.size() << " cell(s), " << total << " local training points";
  report.message = msg.str();
  report.num_added = observations.size();
  report.ok = true;
  fitted = true;
  return report;
}

MultiscaleGpisModel::MultiscaleGpisModel(Config config, GpisModelConfig coarse_config)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(coarse_config))) {
  const Config& c = impl_->config;
  if (!(c.cell_size_m > 0.0) || !(c.overlap_m >= 0.0) || !(c.overlap_m < 0.5 * c.cell_size_m))
    throw std::invalid_argument("MultiscaleGpisModel: need cell_size_m > 0 and 0 <= overlap_m < cell_size_m / 2");
  if (!(c.sigma_min > 0.0 && c.sigma_min <= c.sigma_max) || !(c.length_min_m > 0.0 && c.length_min_m <= impl_->lengthMax()) ||
      !(c.noise_min_m > 0.0 && c.noise_min_m <= c.noise_max_m))
    throw std::invalid_argument("MultiscaleGpisModel: need 0 < min <= max for sigma, length_m and noise_m");
  if (c.max_points_per_cell < 1 || c.coarse_max_surface_points < 4 || !(c.zero_expert_weight > 0.0) ||
      !(c.coarse_probe_voxel_m > 0.0))
    throw std::invalid_argument(
        "MultiscaleGpisModel: need max_points_per_cell >= 1, coarse_max_surface_points >= 4, zero_expert_weight > 0, "
        "coarse_probe_voxel_m > 0");
  impl_->log_fine = impl_->defaultLogFine();
  impl_->fine_tune.message = "no fine tuning ran yet";
}

MultiscaleGpisModel::MultiscaleGpisModel(const MultiscaleGpisModel& other) = default;
MultiscaleGpisModel& MultiscaleGpisModel::operator=(const MultiscaleGpisModel& other) = default;
MultiscaleGpisModel::MultiscaleGpisModel(MultiscaleGpisModel&&) noexcept = default;
MultiscaleGpisModel& MultiscaleGpisModel::operator=(MultiscaleGpisModel&&) noexcept = default;
MultiscaleGpisModel::~MultiscaleGpisModel() = default;

std::unique_ptr<SurfaceModel> MultiscaleGpisModel::clone() const { return std::make_unique<MultiscaleGpisModel>(*this); }

FitReport MultiscaleGpisModel::fit(const std::vector<TrainingPoint>& points) {
  FitReport screen;
  Impl trial(impl_->config, impl_->coarse_config);
  trial.coarse.setHyperparameters(impl_->coarse.hyperparameters());
  trial.log_fine = impl_->log_fine;
  trial.observations = screenObservations(points, kScreenOptions, &screen);
  trial.fine_tune = impl_->fine_tune;
  FitReport report = trial.build(nullptr, 0.0, trial.config.tune_on_fit);
  report.warnings.insert(report.warnings.begin(), screen.warnings.begin(), screen.warnings.end());
  report.num_rejected += screen.num_rejected;
  if (report.ok) *impl_ = std::move(trial);
  return report;
}

FitReport MultiscaleGpisModel::fitInFrame(const std::vector<TrainingPoint>& points, const Vector3& centroid,
                                          double scale) {
  FitReport screen;
  if (!checkFrame(centroid, scale, &screen)) return screen;
  Impl trial(impl_->config, impl_->coarse_config);
  trial.coarse.setHyperparameters(impl_->coarse.hyperparameters());
  trial.log_fine = impl_->log_fine;
  trial.observations = screenObservations(points, kScreenOptions, &screen);
  trial.fine_tune = impl_->fine_tune;
  const bool same_frame = impl_->fitted && centroid == impl_->coarse.centroid() && scale == impl_->coarse.scale();
  // From the current coarse level (a touch retracting guesses).
  FitReport report = trial.build(&centroid, scale, trial.config.tune_on_fit && !same_frame,
                                 impl_->fitted ? &impl_->coarse : nullptr);
  report.warnings.insert(report.warnings.begin(), screen.warnings.begin(), screen.warnings.end());
  report.num_rejected += screen.num_rejected;
  if (report.ok) *impl_ = std::move(trial);
  return report;
}

FitReport MultiscaleGpisModel::Impl::refitWithAdded(const std::vector<TrainingPoint>& added, const FitReport& screen,
                                                    const std::string& why) {
  Impl trial(config, coarse_config);
  trial.coarse.setHyperparameters(coarse.hyperparameters());
  trial.log_fine = log_fine;
  trial.fine_tune = fine_tune;
  trial.observations = observations;
  trial.observations.insert(trial.observations.end(), added.begin(), added.end());
  const Vector3 centroid = coarse.centroid();
  FitReport report = trial.build(&centroid, coarse.scale(), false);
  report.warnings.insert(report.warnings.begin(), screen.warnings.begin(), screen.warnings.end());
  report.num_rejected += screen.num_rejected;
  report.renormalised = report.renormalised || trial.coarse.scale() != coarse.scale() ||
                        trial.coarse.centroid() != coarse.centroid();
  if (report.ok) {
    report.message = why + ": " + report.message;
    report.num_added = added.size();
    *this = std::move(trial);
  }
  return report;
}

// Extended when the thinned selection only grows by new points, refitted in its frame when the
// new free space changes which old points the thinning keeps.
CoarseUpdate MultiscaleGpisModel::Impl::updateCoarse(const std::vector<TrainingPoint>& all, std::size_t old_count) const {
  const std::vector<std::size_t> selection = coarseSelection(all);
  CoarseUpdate update{GpisModel(coarse, selection.size()), selection, false, {}};
  std::vector<std::size_t> extra;
  update.grows = extendsCoarse(selection, old_count, &extra);
  if (update.grows) {
    std::vector<TrainingPoint> extra_points;
    for (std::size_t i : extra) extra_points.push_back(all[i]);
    update.report = extra_points.empty() ? FitReport{} : update.model.addPoints(extra_points);
    if (extra_points.empty()) update.report.ok = true;
  } else {
    std::vector<TrainingPoint> selected;
    for (std::size_t i : selection) selected.push_back(all[i]);
    update.report = update.model.fitInFrame(selected, coarse.centroid(), coarse.scale());
  }
  return update;
}

CellUpdate MultiscaleGpisModel::Impl::updateCells(const Impl& stage, std::size_t old_count) const {
  std::unordered_set<CellKey> dirty;
  std::vector<Eigen::Vector3i> fresh_coords, keys;
  std::unordered_set<CellKey> fresh_seen;
  for (std::size_t i = old_count; i < stage.observations.size(); ++i) {
    const TrainingPoint& p = stage.observations[i];
    if (!isValueObservation(p)) continue;
    cellsContaining(p.position, &keys);
    for (const Eigen::Vector3i& k : keys) dirty.insert(packKey(k));
    if (isSurfaceValue(p)) {
      const Eigen::Vector3i core = coreOf(p.position);
      const CellKey key = packKey(core);
      if (!cell_index.count(key) && fresh_seen.insert(key).second) fresh_coords.push_back(core);
    }
  }
  CellUpdate update;
  std::vector<std::size_t>& rebuilt_index = update.rebuilt_index;
  std::vector<std::size_t>& resolved_index = update.resolved_index;
  for (std::size_t i = 0; i < cells.size(); ++i)
    (dirty.count(packKey(cells[i].coords)) ? rebuilt_index : resolved_index).push_back(i);
  update.created = fresh_coords.size();
  std::vector<Cell>& rebuilt = update.rebuilt;
  rebuilt.resize(rebuilt_index.size() + fresh_coords.size());
  tbb::parallel_for(std::size_t{0}, rebuilt.size(), [&](std::size_t i) {
    rebuilt[i] = stage.makeCell(i < rebuilt_index.size() ? cells[rebuilt_index[i]].coords
                                                         : fresh_coords[i - rebuilt_index.size()]);
  });
  // Unchanged members: only their targets change (m0 moved), so the factor is kept.
  std::vector<Cell>& resolved = update.resolved;
  resolved.resize(resolved_index.size());
  for (std::size_t i = 0; i < resolved.size(); ++i) resolved[i].members = cells[resolved_index[i]].members;
  std::vector<Cell*> targets;
  for (Cell& c : rebuilt) targets.push_back(&c);
  for (Cell& c : resolved) targets.push_back(&c);
  stage.setTargets(targets);
  std::vector<Cell*> to_factor;
  for (Cell& c : rebuilt) to_factor.push_back(&c);
  update.report = stage.factorCells(to_factor);
  if (!update.report.ok) return update;
  tbb::parallel_for(std::size_t{0}, resolved.size(), [&](std::size_t i) {
    resolved[i].alpha = resolved[i].y;
    const auto lower = cells[resolved_index[i]].chol.triangularView<Eigen::Lower>();
    lower.solveInPlace(resolved[i].alpha);
    lower.transpose().solveInPlace(resolved[i].alpha);
  });
  return update;
}

void MultiscaleGpisModel::Impl::commit(Impl&& stage, CellUpdate& update, const std::vector<std::size_t>& coarse_selection) {
  for (std::size_t i = 0; i < update.resolved.size(); ++i) {
    Cell& c = cells[update.resolved_index[i]];
    c.y = std::move(update.resolved[i].y);
    c.alpha = std::move(update.resolved[i].alpha);
  }
  const std::size_t num_rebuilt = update.rebuilt_index.size();
  for (std::size_t i = 0; i < num_rebuilt; ++i) cells[update.rebuilt_index[i]] = std::move(update.rebuilt[i]);
  for (std::size_t i = num_rebuilt; i < update.rebuilt.size(); ++i) {
    cell_index[packKey(update.rebuilt[i].coords)] = cells.size();
    cells.push_back(std::move(update.rebuilt[i]));
  }
  coarse = std::move(stage.coarse);
  coarse_members = coarse_selection;
  observations = std::move(stage.observations);
  buckets = std::move(stage.buckets);
}

FitReport MultiscaleGpisModel::addPoints(const std::vector<TrainingPoint>& points) {
  if (!impl_->fitted) return fit(points);
  FitReport screen;
  std::vector<TrainingPoint> accepted = screenObservations(points, kScreenOptions, &screen);
  if (accepted.empty()) {
    screen.ok = true;
    screen.message = "no valid point to add";
    return screen;
  }
  const Impl& m = *impl_;
  const std::size_t old_count = m.observations.size();
  for (const TrainingPoint& p : accepted)
    if (const char* why = m.refitReason(p)) return impl_->refitWithAdded(accepted, screen, why);

  std::vector<TrainingPoint> all = m.observations;
  all.insert(all.end(), accepted.begin(), accepted.end());
  CoarseUpdate coarse = m.updateCoarse(all, old_count);
  if (!coarse.report.ok) {
    coarse.report.message = "coarse GPIS update failed, model unchanged: " + coarse.report.message;
    return coarse.report;
  }
  if (coarse.model.scale() != m.coarse.scale() || coarse.model.centroid() != m.coarse.centroid())
    return impl_->refitWithAdded(accepted, screen, "the coarse frame moved, refitted");

  // Fine level: on a staging copy of the index structures (cells are moved in at the end).
  Impl stage(m.config, m.coarse_config);
  stage.coarse = std::move(coarse.model);
  stage.observations = std::move(all);
  stage.buckets = m.buckets;
  stage.addToBuckets(old_count);
  stage.log_fine = m.log_fine;
  CellUpdate cells = m.updateCells(stage, old_count);
  if (!cells.report.ok) {
    cells.report.message = "update failed, model unchanged: " + cells.report.message;
    return cells.report;
  }
  impl_->commit(std::move(stage), cells, coarse.selection);  // nothing below can fail

  FitReport report;
  report.ok = true;
  report.full_refit = false;
  report.num_added = accepted.size();
  report.num_rejected = screen.num_rejected;
  report.warnings = screen.warnings;
  report.warnings.insert(report.warnings.end(), coarse.report.warnings.begin(), coarse.report.warnings.end());
  report.warnings.insert(report.warnings.end(), cells.report.warnings.begin(), cells.report.warnings.end());
  std::ostringstream msg;
  msg << "added " << accepted.size() << " point(s): coarse " << (coarse.grows ? "extended" : "refitted in its frame")
      << " (" << coarse.report.message << "); " << cells.rebuilt_index.size() << " cell(s) refactored, " << cells.created
      << " created, " << cells.resolved.size() << " re-solved";
  report.message = msg.str();
  return report;
}

bool MultiscaleGpisModel::isFitted() const { return impl_->fitted; }
const std::vector<TrainingPoint>& MultiscaleGpisModel::observations() const { return impl_->observations; }
ModelFrame MultiscaleGpisModel::frame() const { return impl_->coarse.frame(); }
const MultiscaleGpisModel::Config& MultiscaleGpisModel::config() const { return impl_->config; }
const GpisModel& MultiscaleGpisModel::coarseModel() const { return impl_->coarse; }
std::size_t MultiscaleGpisModel::numCells() const { return impl_->cells.size(); }
const TuneReport& MultiscaleGpisModel::fineTuneReport() const { return impl_->fine_tune; }

double MultiscaleGpisModel::fineLogMarginalLikelihood() const {
  return fineLogMarginalLikelihood(impl_->log_fine, nullptr);
}

double MultiscaleGpisModel::fineLogMarginalLikelihood(const Eigen::Vector3d& log_params, Eigen::Vector3d* gradient) const {
  if (!impl_->fitted) return kNaN;
  return impl_->sampleLogLikelihood(impl_->tuningSample(), log_params, gradient);
}

QuerySlots MultiscaleGpisModel::Impl::querySlots(const Points3& x_world) const {
  const Eigen::Index q = x_world.cols();
  const double s = config.cell_size_m, h = halfWidth();
  QuerySlots query_slots;
  query_slots.slots.resize(static_cast<std::size_t>(q));
  query_slots.count.assign(static_cast<std::size_t>(q), 0);
  tbb::parallel_for(Eigen::Index{0}, q, [&](Eigen::Index col) {
    const Vector3 x = x_world.col(col);
    if (!x.allFinite()) return;
    std::array<std::array<int, 2>, 3> axis{};
    std::array<std::array<double, 2>, 3> weight{}, weight_gradient{};
    std::array<int, 3> n_axis{};
    for (int d = 0; d < 3; ++d) {
      const int base = static_cast<int>(std::floor(x[d] / s));
      for (int c = base - 1; c <= base + 1; ++c) {
        const double t = (x[d] - (c + 0.5) * s) / h;
        if (std::abs(t) >= 1.0 || n_axis[d] == 2) continue;
        axis[d][n_axis[d]] = c;
        weight[d][n_axis[d]] = bump(t);
        weight_gradient[d][n_axis[d]] = bumpDerivative(t) / h;
        ++n_axis[d];
      }
    }
    int& n = query_slots.count[static_cast<std::size_t>(col)];
    for (int a = 0; a < n_axis[0]; ++a)
      for (int bb = 0; bb < n_axis[1]; ++bb)
        for (int c = 0; c < n_axis[2]; ++c) {
          const auto found = cell_index.find(packKey(Eigen::Vector3i(axis[0][a], axis[1][bb], axis[2][c])));
          if (found == cell_index.end()) continue;
          const double wx = weight[0][a], wy = weight[1][bb], wz = weight[2][c];
          const double w = wx * wy * wz;
          if (!(w > 0.0)) continue;
          query_slots.slots[static_cast<std::size_t>(col)][static_cast<std::size_t>(n++)] =
              Slot{found->second, w,
                   Vector3(weight_gradient[0][a] * wy * wz, wx * weight_gradient[1][bb] * wz, wx * wy * weight_gradient[2][c])};
        }
  });
  return query_slots;
}

CellPredictions MultiscaleGpisModel::Impl::predictCells(const Points3& x_world, const CellGroups& groups,
                                                        const Matern52Kernel& kernel, const BatchNeeds& needs) const {
  const std::size_t num_entries = static_cast<std::size_t>(x_world.cols()) * kMaxSlots;
  CellPredictions out;
  out.mean.resize(num_entries);
  out.variance.resize(needs.variance ? num_entries : 0);
  out.gradient.resize(needs.gradient ? num_entries : 0);
  out.variance_gradient.resize(needs.variance_gradient ? num_entries : 0);
  const std::vector<std::size_t>& offset = groups.offset;
  const std::vector<std::size_t>& entries = groups.entries;
  const double prior = kernel.value(0.0);
  // Only the cells some query falls in (a single query must not pay for a pass over every cell).
  std::vector<std::size_t> active;
  for (std::size_t c = 0; c < cells.size(); ++c)
    if (offset[c + 1] > offset[c]) active.push_back(c);
  tbb::parallel_for(std::size_t{0}, active.size(), [&](std::size_t a) {
    const std::size_t c = active[a];
    const std::size_t begin = offset[c], count = offset[c + 1] - begin;
    const Cell& cell = cells[c];
    const Eigen::Index n = cell.x.cols(), mq = static_cast<Eigen::Index>(count);
    Eigen::MatrixXd k(n, mq), slope(needs.slope ? n : 0, needs.slope ? mq : 0);
    Points3 xr(3, mq);
    for (Eigen::Index j = 0; j < mq; ++j) {
      xr.col(j) = x_world.col(static_cast<Eigen::Index>(entries[begin + static_cast<std::size_t>(j)] / kMaxSlots)) - cell.centre;
      for (Eigen::Index i = 0; i < n; ++i) {
        const double r = (xr.col(j) - cell.x.col(i)).norm();
        k(i, j) = kernel.value(r);
        if (needs.slope) slope(i, j) = kernel.derivativeOverDistance(r);
      }
    }
    // Gradient of sum_i a_i k(|x - x_i|): sum_i a_i (dk/dr / r)_i (x - x_i).
    const auto weighted = [&](Eigen::Index j, const auto& coefficients) {
      Vector3 g = Vector3::Zero();
      for (Eigen::Index i = 0; i < n; ++i) g += coefficients[i] * slope(i, j) * (xr.col(j) - cell.x.col(i));
      return g;
    };
    for (Eigen::Index j = 0; j < mq; ++j) {
      const std::size_t e = entries[begin + static_cast<std::size_t>(j)];
      out.mean[e] = k.col(j).dot(cell.alpha);
      if (needs.gradient) out.gradient[e] = weighted(j, cell.alpha);
    }
    if (!needs.variance) return;
    const auto lower = cell.chol.triangularView<Eigen::Lower>();
    lower.solveInPlace(k);  // L^-1 k*
    for (Eigen::Index j = 0; j < mq; ++j)
      out.variance[entries[begin + static_cast<std::size_t>(j)]] = std::max(0.0, prior - k.col(j).squaredNorm());
    if (!needs.variance_gradient) return;
    lower.transpose().solveInPlace(k);  // K^-1 k*
    for (Eigen::Index j = 0; j < mq; ++j)
      out.variance_gradient[entries[begin + static_cast<std::size_t>(j)]] = -2.0 * weighted(j, k.col(j));
  });
  return out;
}

BatchPrediction MultiscaleGpisModel::predictBatch(const Points3& x_world, bool with_gradient, bool with_variance_gradient,
                                                  bool with_variance) const {
  const Impl& m = *impl_;
  if (!m.fitted) throw std::logic_error("MultiscaleGpisModel: query before the model was fitted");
  const Eigen::Index q = x_world.cols();
  const BatchNeeds needs{with_gradient, with_variance_gradient, with_variance || with_variance_gradient,
                         with_gradient || with_variance_gradient};
  BatchPrediction out(q, with_gradient, with_variance_gradient);
  if (q == 0) return out;

  const FineParams p = m.fine();
  const Matern52Kernel kernel = p.kernel();
  const BatchPrediction coarse = coarseBatch(m.coarse, x_world, needs);
  const QuerySlots query_slots = m.querySlots(x_world);
  const CellPredictions cells = m.predictCells(x_world, groupByCell(query_slots, m.cells.size()), kernel, needs);
  blendLevels(coarse, query_slots, cells, kernel, m.config.zero_expert_weight, m.coarse.varianceUnitFactor(), needs, out);
  return out;
}

double MultiscaleGpisModel::Impl::cellWeight(const Eigen::Vector3i& coords, const Vector3& x) const {
  const double s = config.cell_size_m, h = halfWidth();
  double w = 1.0;
  for (int d = 0; d < 3; ++d) w *= bump((x[d] - (coords[d] + 0.5) * s) / h);
  return w;
}

std::vector<std::vector<TrainingPoint>> MultiscaleGpisModel::Impl::coarseShares(
    const std::vector<std::vector<TrainingPoint>>& accepted, std::vector<char>* by_refit) const {
  std::vector<std::vector<TrainingPoint>> shares(accepted.size());
  for (std::size_t b = 0; b < accepted.size(); ++b) {
    for (const TrainingPoint& p : accepted[b])
      if (refitReason(p)) (*by_refit)[b] = 1;
    if ((*by_refit)[b] || accepted[b].empty()) continue;
    std::vector<TrainingPoint> all = observations;
    all.insert(all.end(), accepted[b].begin(), accepted[b].end());
    std::vector<std::size_t> extra;
    if (!extendsCoarse(coarseSelection(all), observations.size(), &extra)) {
      (*by_refit)[b] = 1;
      continue;
    }
    for (std::size_t i : extra) shares[b].push_back(all[i]);
  }
  return shares;
}

MultiscaleGpisModel::Impl::FantasyCells MultiscaleGpisModel::Impl::fantasyCells(
    const std::vector<TrainingPoint>& accepted) const {
  FantasyCells out;
  std::unordered_map<CellKey, std::size_t> fresh;  // key -> index in out.created
  for (const TrainingPoint& point : accepted) {
    if (!isSurfaceValue(point)) continue;
    const Eigen::Vector3i core = coreOf(point.position);
    if (!cell_index.count(packKey(core)) && fresh.emplace(packKey(core), out.created.size()).second)
      out.created.push_back({core, {}});
  }
  std::vector<Eigen::Vector3i> keys;
  for (const TrainingPoint& point : accepted) {
    if (!isValueObservation(point)) continue;
    cellsContaining(point.position, &keys);
    for (const Eigen::Vector3i& key : keys) {
      if (const auto found = cell_index.find(packKey(key)); found != cell_index.end())
        out.existing[found->second].push_back(point.position);
      else if (const auto created = fresh.find(packKey(key)); created != fresh.end())
        out.created[created->second].points.push_back(point.position);
    }
  }
  return out;
}

void MultiscaleGpisModel::Impl::lowerCellVariance(std::size_t c, const std::vector<Vector3>& points,
                                                  const Eigen::MatrixXd& solved_queries, const Points3& x_world,
                                                  const CellGroups& groups, std::vector<double>* variance) const {
  // A rank-k update of the cell's posterior: var'(x) = var(x) - c^T S^-1 c.
  const FineParams p = fine();
  const Matern52Kernel kernel(p.sigma, p.length_m);
  const Cell& cell = cells[c];
  const Eigen::Index k = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixXd v_new(cell.x.cols(), k), schur(k, k);
  for (Eigen::Index a = 0; a < k; ++a) {
    const Vector3& pa = points[static_cast<std::size_t>(a)];
    for (Eigen::Index i = 0; i < cell.x.cols(); ++i) v_new(i, a) = kernel.value((pa - cell.centre - cell.x.col(i)).norm());
    for (Eigen::Index d = 0; d < k; ++d) schur(a, d) = kernel.value((pa - points[static_cast<std::size_t>(d)]).norm());
    schur(a, a) += noiseVar(p) + cell.jitter;
  }
  cell.chol.triangularView<Eigen::Lower>().solveInPlace(v_new);
  schur.noalias() -= v_new.transpose() * v_new;
  const std::size_t begin = groups.offset[c];
  Eigen::MatrixXd cross = -v_new.transpose() * solved_queries;
  for (Eigen::Index j = 0; j < cross.cols(); ++j) {
    const Vector3 x = x_world.col(static_cast<Eigen::Index>(groups.entries[begin + static_cast<std::size_t>(j)] / kMaxSlots));
    for (Eigen::Index a = 0; a < k; ++a) cross(a, j) += kernel.value((x - points[static_cast<std::size_t>(a)]).norm());
  }
  Eigen::LLT<Eigen::MatrixXd> llt(schur);
  if (llt.info() != Eigen::Success) return;
  llt.matrixL().solveInPlace(cross);
  for (Eigen::Index j = 0; j < cross.cols(); ++j) {
    double& v = (*variance)[groups.entries[begin + static_cast<std::size_t>(j)]];
    v = std::max(0.0, v - cross.col(j).squaredNorm());
  }
}

std::vector<Cell> MultiscaleGpisModel::Impl::buildFantasyCells(const std::vector<NewCell>& created) const {
  const FineParams p = fine();
  const Matern52Kernel kernel(p.sigma, p.length_m);
  std::vector<Cell> built;
  for (const NewCell& fresh : created) {
    // Its members: the bucket of its region (value observations held) and the batch's new points.
    Cell cell;
    cell.coords = fresh.coords;
    cell.centre = (fresh.coords.cast<double>().array() + 0.5).matrix() * config.cell_size_m;
    std::vector<Vector3> members;
    if (const auto bucket = buckets.find(packKey(fresh.coords)); bucket != buckets.end())
      for (std::size_t i : bucket->second) members.push_back(observations[i].position);
    members.insert(members.end(), fresh.points.begin(), fresh.points.end());
    cell.x.resize(3, static_cast<Eigen::Index>(members.size()));
    for (std::size_t i = 0; i < members.size(); ++i) cell.x.col(static_cast<Eigen::Index>(i)) = members[i] - cell.centre;
    cell.y = Eigen::VectorXd::Zero(cell.x.cols());
    if (factoriseCell(&cell, kernel, noiseVar(p), coarse_config.cholesky)) built.push_back(std::move(cell));
  }
  return built;
}

double MultiscaleGpisModel::Impl::blendedFineVariance(const Vector3& x, const std::array<Slot, kMaxSlots>& slots, int count,
                                                      const double* slot_variance, const std::vector<Cell>& built) const {
  const FineParams p = fine();
  const Matern52Kernel kernel(p.sigma, p.length_m);
  const double s2 = p.sigma * p.sigma, w0 = config.zero_expert_weight;
  double sum_w = w0, sum_wv = w0 * s2;
  for (int k = 0; k < count; ++k) {
    sum_w += slots[static_cast<std::size_t>(k)].weight;
    sum_wv += slots[static_cast<std::size_t>(k)].weight * slot_variance[k];
  }
  for (const Cell& cell : built) {
    const double w = cellWeight(cell.coords, x);
    if (!(w > 0.0)) continue;
    Eigen::VectorXd kx(cell.x.cols());
    for (Eigen::Index i = 0; i < cell.x.cols(); ++i) kx[i] = kernel.value((x - cell.centre - cell.x.col(i)).norm());
    cell.chol.triangularView<Eigen::Lower>().solveInPlace(kx);
    sum_w += w;
    sum_wv += w * std::max(0.0, s2 - kx.squaredNorm());
  }
  return sum_wv / sum_w;
}

Eigen::MatrixXd MultiscaleGpisModel::varianceAfter(const Points3& x_world,
                                                   const std::vector<std::vector<TrainingPoint>>& touches) const {
  const Impl& m = *impl_;
  if (!m.fitted) throw std::logic_error("MultiscaleGpisModel: query before the model was fitted");
  const std::size_t num_batches = touches.size();
  std::vector<std::vector<TrainingPoint>> accepted(num_batches);
  for (std::size_t b = 0; b < num_batches; ++b) {
    FitReport screen;
    accepted[b] = screenObservations(touches[b], kScreenOptions, &screen);
  }
  std::vector<char> by_refit(num_batches, 0);
  Eigen::MatrixXd after = m.coarse.varianceAfter(x_world, m.coarseShares(accepted, &by_refit));

  // The fine level: each query's cells and their variances now, then each batch's cells.
  const FineParams p = m.fine();
  const Matern52Kernel kernel(p.sigma, p.length_m);
  const QuerySlots slots = m.querySlots(x_world);
  const CellGroups groups = groupByCell(slots, m.cells.size());
  const CellPredictions before =
      m.predictCells(x_world, groups, kernel, BatchNeeds{false, false, true, false});
  std::vector<Impl::FantasyCells> fantasy(num_batches);
  std::unordered_map<std::size_t, Eigen::MatrixXd> solved_queries;  // L^-1 k(X_c, x) of a changed cell's queries
  for (std::size_t b = 0; b < num_batches; ++b) {
    if (by_refit[b]) continue;
    fantasy[b] = m.fantasyCells(accepted[b]);
    for (const auto& entry : fantasy[b].existing) solved_queries[entry.first];
  }
  std::vector<std::size_t> changed;
  for (const auto& entry : solved_queries) changed.push_back(entry.first);
  tbb::parallel_for(std::size_t{0}, changed.size(), [&](std::size_t t) {
    const Cell& cell = m.cells[changed[t]];
    const std::size_t begin = groups.offset[changed[t]], count = groups.offset[changed[t] + 1] - begin;
    Eigen::MatrixXd& k = solved_queries.at(changed[t]);
    k.resize(cell.x.cols(), static_cast<Eigen::Index>(count));
    for (std::size_t j = 0; j < count; ++j) {
      const Vector3 x = x_world.col(static_cast<Eigen::Index>(groups.entries[begin + j] / kMaxSlots)) - cell.centre;
      for (Eigen::Index i = 0; i < cell.x.cols(); ++i) k(i, static_cast<Eigen::Index>(j)) = kernel.value((x - cell.x.col(i)).norm());
    }
    cell.chol.triangularView<Eigen::Lower>().solveInPlace(k);
  });
  const double unit = m.coarse.varianceUnitFactor();
  tbb::parallel_for(std::size_t{0}, num_batches, [&](std::size_t b) {
    if (by_refit[b]) return;
    std::vector<double> variance = before.variance;  // per (query, slot)
    for (const auto& [c, points] : fantasy[b].existing)
      m.lowerCellVariance(c, points, solved_queries.at(c), x_world, groups, &variance);
    const std::vector<Cell> built = m.buildFantasyCells(fantasy[b].created);
    for (Eigen::Index col = 0; col < x_world.cols(); ++col) {
      const std::size_t jq = static_cast<std::size_t>(col);
      after(col, static_cast<Eigen::Index>(b)) +=
          unit * m.blendedFineVariance(x_world.col(col), slots.slots[jq], slots.count[jq], &variance[jq * kMaxSlots], built);
    }
  });
  std::vector<std::vector<TrainingPoint>> refitted;
  for (std::size_t b = 0; b < num_batches; ++b)
    if (by_refit[b]) refitted.push_back(touches[b]);
  if (!refitted.empty()) {
    const Eigen::MatrixXd cloned = SurfaceModel::varianceAfter(x_world, refitted);
    for (std::size_t b = 0, i = 0; b < num_batches; ++b)
      if (by_refit[b]) after.col(static_cast<Eigen::Index>(b)) = cloned.col(static_cast<Eigen::Index>(i++));
  }
  return after;
}

std::vector<std::string> MultiscaleGpisModel::hyperparameterNames() const {
  std::vector<std::string> names;
  for (const std::string& n : impl_->coarse.hyperparameterNames()) names.push_back("coarse_" + n);
  names.insert(names.end(), {"fine_log_sigma", "fine_log_length_m", "fine_log_noise_m"});
  return names;
}

Eigen::VectorXd MultiscaleGpisModel::hyperparameters() const {
  const Eigen::VectorXd coarse = impl_->coarse.hyperparameters();
  Eigen::VectorXd all(coarse.size() + 3);
  all << coarse, impl_->log_fine;
  return all;
}

FitReport MultiscaleGpisModel::setHyperparameters(const Eigen::VectorXd& log_params) {
  FitReport report;
  Impl trial(impl_->config, impl_->coarse_config);
  if (!impl_->withHyperparameters(log_params, &trial, &report)) return report;
  if (!impl_->fitted) {
    *impl_ = std::move(trial);
    report.message = "hyperparameters set; model not fitted yet";
    return report;
  }
  trial.observations = impl_->observations;
  const Vector3 centroid = impl_->coarse.centroid();
  report = trial.build(&centroid, impl_->coarse.scale(), false);
  if (report.ok) *impl_ = std::move(trial);
  return report;
}

FitReport MultiscaleGpisModel::restore(const SurfaceModelState& state) {
  FitReport report;
  if (!checkStateModel(state, &report) || !checkFrame(state.centroid, state.scale, &report)) return report;
  const Eigen::VectorXd params =
      Eigen::Map<const Eigen::VectorXd>(state.hyperparameters.data(), static_cast<Eigen::Index>(state.hyperparameters.size()));
  Impl trial(impl_->config, impl_->coarse_config);
  if (!impl_->withHyperparameters(params, &trial, &report)) return report;
  FitReport screen;
  trial.observations = screenObservations(state.observations, kScreenOptions, &screen);
  report = trial.build(&state.centroid, state.scale, false);
  report.warnings.insert(report.warnings.begin(), screen.warnings.begin(), screen.warnings.end());
  if (report.ok) {
    *impl_ = std::move(trial);
    setPositionSdScale(state.position_sd_scale);
  }
  return report;
}

}  // namespace gpatlas_core
