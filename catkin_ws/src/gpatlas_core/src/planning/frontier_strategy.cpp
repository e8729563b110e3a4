#include "gpatlas_core/planning/frontier_strategy.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>
#include <sstream>

namespace gpatlas_core {

namespace {

using Cell = UnknownSpace::Cell;

// A cell index as a vector index.
std::size_t at(long k) { return static_cast<std::size_t>(k); }

// How far a probe's free-space points may lie from the line of its path (metres): the probe's
// path is straight, its points lie on it to rounding.
constexpr double kStrokeTolerance_m = 0.002;

bool candidate(Cell c) { return c == Cell::kUnknown || c == Cell::kCleared || c == Cell::kTooSmall; }

// The grid's frame: cubic, about the model's centroid, with cells of cell_m or, for a large
// object, coarser: at most kMaxCellsPerAxis per axis bounds the plan's memory and time.
constexpr int kMaxCellsPerAxis = 160;
UnknownSpace emptyGrid(const SurfaceModel& model, const FrontierStrategy::Config& c) {
  UnknownSpace space;
  const double half = c.search_radius_fraction * model.dataRadiusWorld();
  const double cell = std::max(c.cell_m, 2.0 * half / kMaxCellsPerAxis);
  const int n = std::clamp(static_cast<int>(std::ceil(2.0 * half / cell)), 1, kMaxCellsPerAxis);
  space.cell_m = cell;
  space.size = Eigen::Vector3i::Constant(n);
  space.origin = model.centroid() - Vector3::Constant(0.5 * (n - 1) * cell);
  space.cells.assign(at(n) * n * n, Cell::kIgnored);
  space.distance_m.assign(space.cells.size(), std::numeric_limits<float>::infinity());
  space.shadow_depth_m.assign(space.cells.size(), 0.0f);
  return space;
}

// kPredicted where the model's mean is negative, evaluated in batches at the cells `hidden` marks
// (the predicted object lies behind the seen surface); whether each of those is in the domain.
void markPredicted(const SurfaceModel& model, const std::vector<bool>& hidden, UnknownSpace& space,
                   std::vector<bool>& in_domain) {
  constexpr long kBatch = 4096;
  std::vector<long> cells;
  for (long k = 0; k < static_cast<long>(space.cells.size()); ++k)
    if (hidden[at(k)]) cells.push_back(k);
  in_domain.assign(space.cells.size(), false);
  const long total = static_cast<long>(cells.size());
  for (long first = 0; first < total; first += kBatch) {
    const long count = std::min(kBatch, total - first);
    Points3 points(3, count);
    for (long k = 0; k < count; ++k) points.col(k) = space.centre(cells[at(first + k)]);
    const BatchPrediction p = model.predictBatch(points, false, false, false);
    for (long k = 0; k < count; ++k) {
      const std::size_t cell = static_cast<std::size_t>(cells[at(first + k)]);
      in_domain[cell] = p.in_domain(k);
      if (p.in_domain(k) && p.mean(k) < 0.0) space.cells[cell] = Cell::kPredicted;
    }
  }
}

// Calls f(m) for each of the up to 26 neighbours m of cell k in a grid of `n` cells.
template <typename F>
void forEachNeighbour(const Eigen::Vector3i& n, long k, F&& f) {
  const long i = k % n.x(), j = (k / n.x()) % n.y(), l = k / (static_cast<long>(n.x()) * n.y());
  for (int dl = -1; dl <= 1; ++dl)
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        if (di == 0 && dj == 0 && dl == 0) continue;
        const long a = i + di, b = j + dj, c = l + dl;
        if (a < 0 || b < 0 || c < 0 || a >= n.x() || b >= n.y() || c >= n.z()) continue;
        f(a + n.x() * (b + static_cast<long>(n.y()) * c));
      }
}

// Each cell's distance to the nearest `source` cell, up to `reach` (infinity beyond): a
// breadth-first sweep from them that carries its nearest source (exact to within a cell).
std::vector<float> distanceFrom(const UnknownSpace& space, const std::vector<bool>& is_source, double reach) {
  const Eigen::Vector3i& n = space.size;
  std::vector<float> distance(space.cells.size(), std::numeric_limits<float>::infinity());
  std::vector<long> source(space.cells.size(), -1);
  std::deque<long> queue;
  for (long k = 0; k < static_cast<long>(space.cells.size()); ++k)
    if (is_source[at(k)]) {
      source[at(k)] = k;
      distance[at(k)] = 0.0f;
      queue.push_back(k);
    }
  while (!queue.empty()) {
    const long k = queue.front();
    queue.pop_front();
    const Vector3 from = space.centre(source[at(k)]);
    forEachNeighbour(n, k, [&](long m) {
      const float d = static_cast<float>((space.centre(m) - from).norm());
      if (d > reach || !(d < distance[at(m)])) return;
      distance[at(m)] = d;
      source[at(m)] = source[at(k)];
      queue.push_back(m);
    });
  }
  return distance;
}

// Marks every candidate cell within `radius` of p as cleared.
void clearAround(UnknownSpace& space, const Vector3& p, double radius) {
  const int r = static_cast<int>(std::ceil(radius / space.cell_m));
  const Vector3 g = (p - space.origin) / space.cell_m;
  const Eigen::Vector3i c(static_cast<int>(std::lround(g.x())), static_cast<int>(std::lround(g.y())),
                          static_cast<int>(std::lround(g.z())));
  for (int dl = -r; dl <= r; ++dl)
    for (int dj = -r; dj <= r; ++dj)
      for (int di = -r; di <= r; ++di) {
        const Eigen::Vector3i q = c + Eigen::Vector3i(di, dj, dl);
        if ((q.array() < 0).any() || (q.array() >= space.size.array()).any()) continue;
        const long m = q.x() + space.size.x() * (q.y() + static_cast<long>(space.size.y()) * q.z());
        Cell& cell = space.cells[at(m)];
        if (candidate(cell) && (space.centre(m) - p).norm() <= radius) cell = Cell::kCleared;
      }
}

// Connected pieces of kUnknown: those smaller than `min_cells` become kTooSmall. Returns how
// many pieces are left.
int dropSmallPieces(UnknownSpace& space, int min_cells) {
  const Eigen::Vector3i& n = space.size;
  std::vector<bool> seen(space.cells.size(), false);
  int pieces = 0;
  for (long start = 0; start < static_cast<long>(space.cells.size()); ++start) {
    if (seen[at(start)] || space.cells[at(start)] != Cell::kUnknown) continue;
    std::vector<long> piece{start};
    seen[at(start)] = true;
    for (std::size_t head = 0; head < piece.size(); ++head) {
      forEachNeighbour(n, piece[head], [&](long m) {
        if (seen[at(m)] || space.cells[at(m)] != Cell::kUnknown) return;
        seen[at(m)] = true;
        piece.push_back(m);
      });
    }
    if (static_cast<int>(piece.size()) < min_cells) {
      for (long k : piece) space.cells[at(k)] = Cell::kTooSmall;
    } else {
      ++pieces;
      space.unknown_cells += static_cast<int>(piece.size());
    }
  }
  return pieces;
}

// The positions a run's touches measured, from the model's observations: the contacts and the
// free space.
struct TouchedPositions {
  std::vector<Vector3> contacts, free_space;
};
TouchedPositions touchedPositions(const SurfaceModel& model) {
  TouchedPositions touched;
  for (const TrainingPoint& p : model.observations()) {
    if (p.source == PointSource::kTouch && !observesSlope(p)) touched.contacts.push_back(p.position);
    else if (p.source == PointSource::kFreeSpace) touched.free_space.push_back(p.position);
  }
  return touched;
}

// Marks the candidate cells a probe's straight path crossed as cleared. Every probe moves along a
// line through the point its touch aimed at, so the free space the model holds near an attempted
// target that lines up with it is that touch's path: the line through the target with the most of
// those points within `tolerance` of it, from the farthest on one side to the farthest on the other.
// The model keeps a touch's free space about 15 mm apart; the cells between them were crossed too.
void clearStroke(UnknownSpace& space, const Vector3& target, const std::vector<Vector3>& free_space, double length,
                 double tolerance) {
  std::vector<Vector3> near;
  for (const Vector3& p : free_space)
    if ((p - target).norm() <= length && (p - target).norm() > tolerance) near.push_back(p);
  int best_count = 0;
  Vector3 best_direction = Vector3::Zero();
  for (const Vector3& q : near) {
    const Vector3 d = (q - target).normalized();
    int count = 0;
    for (const Vector3& p : near) count += ((p - target) - (p - target).dot(d) * d).norm() <= tolerance;
    if (count > best_count) {
      best_count = count;
      best_direction = d;
    }
  }
  if (best_count < 2) return;
  double lo = 0.0, hi = 0.0;
  for (const Vector3& p : near)
    if (((p - target) - (p - target).dot(best_direction) * best_direction).norm() <= tolerance) {
      lo = std::min(lo, (p - target).dot(best_direction));
      hi = std::max(hi, (p - target).dot(best_direction));
    }
  for (double s = lo; s <= hi; s += 0.02 * space.cell_m) {
    const long k = space.index(target + s * best_direction);
    if (k >= 0 && candidate(space.cells[at(k)])) space.cells[at(k)] = Cell::kCleared;
  }
}

// One candidate poke: its target, approach direction (outward: the probe moves along minus it)
// and expected gain.
struct ShadowPoke {
  Vector3 target;
  Vector3 direction;
  double gain{0.0};
};

}  // namespace

long UnknownSpace::index(const Vector3& x) const {
  if (cells.empty() || !x.allFinite()) return -1;
  const Vector3 g = (x - origin) / cell_m;
  const long i = std::lround(g.x()), j = std::lround(g.y()), k = std::lround(g.z());
  if (i < 0 || j < 0 || k < 0 || i >= size.x() || j >= size.y() || k >= size.z()) return -1;
  return i + size.x() * (j + static_cast<long>(size.y()) * k);
}

Vector3 UnknownSpace::centre(long index) const {
  const long i = index % size.x(), j = (index / size.x()) % size.y();
  const long k = index / (static_cast<long>(size.x()) * size.y());
  return origin + cell_m * Vector3(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
}

std::string validate(const FrontierStrategy::Config& c) {
  std::ostringstream problem;
  auto positive = [&](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) problem << name << " must be positive and finite; ";
  };
  positive(c.cell_m, "cell_m");
  positive(c.search_radius_fraction, "search_radius_fraction");
  positive(c.reach_m, "reach_m");
  positive(c.clear_radius_m, "clear_radius_m");
  positive(c.approach_distance_m, "approach_distance_m");
  if (!(c.observed_within_m >= c.approach_distance_m) || !std::isfinite(c.observed_within_m))
    problem << "observed_within_m must be finite and >= approach_distance_m; ";
  positive(c.prior_length_m, "prior_length_m");
  positive(c.part_size_m, "part_size_m");
  positive(c.shadow.bin_m, "shadow.bin_m");
  positive(c.shadow.depth_margin_m, "shadow.depth_margin_m");
  if (!(c.min_gap_m >= 0.0) || !(c.min_gap_m < c.reach_m)) problem << "min_gap_m must be in [0, reach_m); ";
  if (!(c.support_clearance_m >= 0.0) || !std::isfinite(c.support_clearance_m))
    problem << "support_clearance_m must be >= 0; ";
  if (!(c.past_m >= 0.0) || !std::isfinite(c.past_m)) problem << "past_m must be >= 0; ";
  if (c.min_cluster_cells < 1) problem << "min_cluster_cells must be >= 1; ";
  if (c.approach_directions < 1 || c.max_targets < 1 || c.max_reachability_checks < 1)
    problem << "approach_directions, max_targets and max_reachability_checks must be >= 1; ";
  if (c.max_empty_pokes < 0) problem << "max_empty_pokes must be >= 0; ";
  return problem.str();
}

void readFrontier(ParamReader& r, FrontierStrategy::Config* c) {
  c->cell_m = r.number("frontier/cell_m", c->cell_m, 1e-3, 0.1);
  // Beyond the fixed min_gap_m, nearer than which the atlas's own touches measure.
  c->reach_m = r.number("frontier/reach_m", c->reach_m, std::nextafter(c->min_gap_m, 1.0), 1.0);
  c->max_empty_pokes = r.integer("frontier/max_empty_pokes", c->max_empty_pokes, 0, 1000);
}

FrontierStrategy::FrontierStrategy(Config config, AtlasPlanner::Config atlas, std::uint64_t seed)
    : config_(std::move(config)), poke_(AtlasStrategy::Mode::kPoke, std::move(atlas), seed) {
  if (const std::string problem = validate(config_); !problem.empty())
    throw std::invalid_argument("atlas_frontier: " + problem);
}

UnknownSpace FrontierStrategy::unknownSpace(const SurfaceModel& model, const EvidenceState& state) const {
  return unknownSpace(model, state, ViewShadow(state.views, config_.shadow));
}

UnknownSpace FrontierStrategy::unknownSpace(const SurfaceModel& model, const EvidenceState& state,
                                            const ViewShadow& shadow) const {
  UnknownSpace space = emptyGrid(model, config_);
  if (shadow.empty()) return space;
  std::vector<bool> hidden(space.cells.size(), false);
  for (long k = 0; k < static_cast<long>(space.cells.size()); ++k)
    hidden[at(k)] = shadow.hidden(space.centre(k));
  std::vector<bool> in_domain;
  markPredicted(model, hidden, space, in_domain);
  std::vector<bool> predicted(space.cells.size()), seen(space.cells.size());
  for (std::size_t k = 0; k < space.cells.size(); ++k) {
    predicted[k] = space.cells[k] == Cell::kPredicted;
    seen[k] = !hidden[k];
  }
  space.distance_m = distanceFrom(space, predicted, config_.reach_m);
  space.shadow_depth_m = distanceFrom(space, seen, config_.part_size_m);
  for (long k = 0; k < static_cast<long>(space.cells.size()); ++k) {
    Cell& cell = space.cells[at(k)];
    const float d = space.distance_m[at(k)];
    if (cell == Cell::kPredicted || !in_domain[at(k)] || d < config_.min_gap_m || !(d <= config_.reach_m)) continue;
    if (state.support_plane && state.support_plane->height(space.centre(k)) < config_.support_clearance_m) continue;
    cell = Cell::kUnknown;
  }
  const TouchedPositions touched = touchedPositions(model);
  for (const Vector3& p : touched.contacts) clearAround(space, p, config_.clear_radius_m);
  for (const Vector3& p : touched.free_space) clearAround(space, p, config_.clear_radius_m);
  for (const Vector3& p : state.attempted_targets) clearAround(space, p, config_.clear_radius_m);
  for (const Vector3& target : state.attempted_targets)
    clearStroke(space, target, touched.free_space, 2.0 * config_.approach_distance_m + config_.past_m,
                kStrokeTolerance_m);
  space.clusters = dropSmallPieces(space, config_.min_cluster_cells);
  return space;
}

PlanResult FrontierStrategy::plan(const SurfaceModel& model, const PlanRequest& request) const {
  if (auto error = checkPlanInput(model, request)) return *error;
  PlanResult result = poke_.plan(model, request);
  if (result.status == PlanStatus::kTouch) result.touch.strategy = name();
  if (result.status != PlanStatus::kConverged || request.evidence_state.views.empty()) return result;
  return planShadowPoke(model, request, std::move(result));
}

namespace {

// The chance that unknown cell k holds a part the views missed: a part is attached to the object,
// so it lies near the predicted one (prior_length_m), and it lies wholly in the shadow, so a part
// of part_size_m fits only that deep in it (nearer observed space, a part would have shown).
double partChance(const UnknownSpace& space, long k, const FrontierStrategy::Config& c) {
  const double near = std::exp(-static_cast<double>(space.distance_m[at(k)]) / c.prior_length_m);
  const double depth = static_cast<double>(space.shadow_depth_m[at(k)]);
  return near * std::min(1.0, depth / c.part_size_m);
}

// Whether the approach line through `target` along `d` comes from observed space: from the
// probe's start outward, within observed_within_m of the target, it reaches a point no view
// hides (or a touch cleared), above the table and outside the predicted object all the way.
bool comesFromObservedSpace(const UnknownSpace& space, const ViewShadow& shadow, const EvidenceState& state,
                            const Vector3& target, const Vector3& d, const FrontierStrategy::Config& c) {
  for (double s = c.approach_distance_m; s <= c.observed_within_m; s += space.cell_m) {
    const Vector3 x = target + s * d;
    if (state.support_plane && state.support_plane->height(x) < c.support_clearance_m) return false;
    const long k = space.index(x);
    const Cell cell = k >= 0 ? space.cells[at(k)] : Cell::kIgnored;
    if (cell == Cell::kPredicted) return false;
    if (cell == Cell::kCleared || !shadow.hidden(x)) return true;
  }
  return false;
}

// The best approach to `target` and its gain: the direction whose path, from observed space
// through the target to past_m beyond it, does not cross the predicted object before the target,
// and crosses the most weighted unknown cells.
ShadowPoke bestApproach(const UnknownSpace& space, const ViewShadow& shadow, const EvidenceState& state,
                        const std::vector<Vector3>& directions, const Vector3& target,
                        const FrontierStrategy::Config& c) {
  ShadowPoke best{target, Vector3::Zero(), 0.0};
  const double step = 0.5 * space.cell_m;
  for (const Vector3& d : directions) {
    double gain = 0.0;
    long last = -1;
    bool blocked = false;
    for (double s = c.approach_distance_m; s >= -c.past_m; s -= step) {
      const Vector3 x = target + s * d;
      const bool before_target = s > 0.0;
      if (state.support_plane && state.support_plane->height(x) < 0.0) {
        blocked = before_target;
        break;
      }
      const long k = space.index(x);
      if (k < 0 || k == last) continue;
      last = k;
      const Cell cell = space.cells[at(k)];
      if (cell == Cell::kPredicted) {
        blocked = before_target;
        break;
      }
      if (cell == Cell::kUnknown) gain += partChance(space, k, c);
    }
    if (blocked || !(gain > best.gain) || !comesFromObservedSpace(space, shadow, state, target, d, c)) continue;
    best = ShadowPoke{target, d, gain};
  }
  return best;
}

}  // namespace

PlanResult FrontierStrategy::planShadowPoke(const SurfaceModel& model, const PlanRequest& request,
                                            PlanResult result) const {
  const auto started = std::chrono::steady_clock::now();
  const ViewShadow shadow(request.evidence_state.views, config_.shadow);
  const UnknownSpace space = unknownSpace(model, request.evidence_state, shadow);
  std::ostringstream note;
  note << "; unknown space: " << space.unknown_cells << " cells in " << space.clusters << " pieces, "
       << request.evidence_state.empty_unknown_pokes << " empty pokes so far";
  auto finish = [&](PlanResult r) {
    r.elapsed_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    r.message += note.str();
    return r;
  };
  if (space.unknown_cells == 0) return finish(std::move(result));
  if (request.evidence_state.empty_unknown_pokes >= config_.max_empty_pokes) {
    note << " (the budget of " << config_.max_empty_pokes << " is spent)";
    return finish(std::move(result));
  }
  std::vector<long> unknown;
  for (long k = 0; k < static_cast<long>(space.cells.size()); ++k)
    if (space.cells[at(k)] == Cell::kUnknown) unknown.push_back(k);
  const std::size_t stride = (unknown.size() + static_cast<std::size_t>(config_.max_targets) - 1) /
                             static_cast<std::size_t>(config_.max_targets);
  const std::vector<Vector3> directions = fibonacciSphere(config_.approach_directions);
  std::vector<ShadowPoke> pokes;
  for (std::size_t n = 0; n < unknown.size(); n += stride) {
    const ShadowPoke poke =
        bestApproach(space, shadow, request.evidence_state, directions, space.centre(unknown[n]), config_);
    if (poke.gain > 0.0) pokes.push_back(poke);
  }
  std::sort(pokes.begin(), pokes.end(), [](const ShadowPoke& a, const ShadowPoke& b) { return a.gain > b.gain; });
  for (std::size_t n = 0; n < pokes.size() && n < static_cast<std::size_t>(config_.max_reachability_checks); ++n) {
    std::optional<Vector3> direction = pokes[n].direction;
    if (request.reachable) direction = request.reachable(pokes[n].target, pokes[n].direction);
    if (!direction) {
      ++result.unreachable_candidates;
      continue;
    }
    result.status = PlanStatus::kTouch;
    result.touch = Touch();
    result.touch.kind = Touch::Kind::kPoke;
    result.touch.strategy = name();
    result.touch.explores_unknown = true;
    result.touch.points = {pokes[n].target};
    result.touch.normals = {direction->normalized()};
    result.touch.variances = {model.variance(pokes[n].target)};
    note << "; shadow poke with expected gain " << pokes[n].gain;
    return finish(std::move(result));
  }
  note << "; no reachable poke into it (" << pokes.size() << " with an approach from observed space)";
  return finish(std::move(result));
}

}  // namespace gpatlas_core
