#include "gpatlas_core/planning/atlas.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace gpatlas_core {

namespace {

// 21 bits per coordinate: +-20 km at 2 cm cells, far beyond any model's domain.
constexpr std::int64_t kCoordinateBits = 21;
constexpr std::int64_t kCoordinateOffset = std::int64_t{1} << (kCoordinateBits - 1);

std::int64_t packCell(std::int64_t i, std::int64_t j, std::int64_t k) {
  const auto field = [](std::int64_t v) { return (v + kCoordinateOffset) & ((std::int64_t{1} << kCoordinateBits) - 1); };
  return (field(i) << (2 * kCoordinateBits)) | (field(j) << kCoordinateBits) | field(k);
}

}  // namespace

Atlas::CellKey Atlas::cellOf(const Vector3& x) const {
  return packCell(static_cast<std::int64_t>(std::floor(x.x() / kCell_m)),
                  static_cast<std::int64_t>(std::floor(x.y() / kCell_m)),
                  static_cast<std::int64_t>(std::floor(x.z() / kCell_m)));
}

void Atlas::forChartsNear(const Vector3& x, double reach, const std::function<void(int)>& visit) const {
  if (!x.allFinite()) return;
  const auto span = static_cast<std::int64_t>(std::ceil(reach / kCell_m));
  const std::int64_t ci = static_cast<std::int64_t>(std::floor(x.x() / kCell_m));
  const std::int64_t cj = static_cast<std::int64_t>(std::floor(x.y() / kCell_m));
  const std::int64_t ck = static_cast<std::int64_t>(std::floor(x.z() / kCell_m));
  for (std::int64_t i = ci - span; i <= ci + span; ++i)
    for (std::int64_t j = cj - span; j <= cj + span; ++j)
      for (std::int64_t k = ck - span; k <= ck + span; ++k) {
        const auto found = cells_.find(packCell(i, j, k));
        if (found == cells_.end()) continue;
        for (int index : found->second) visit(index);
      }
}

void Atlas::index(int chart_index) {
  const Chart& chart = charts_[static_cast<std::size_t>(chart_index)];
  cells_[cellOf(chart.centre)].push_back(chart_index);
  max_radius_ = std::max(max_radius_, chart.radius);
}

bool Atlas::coveredByOtherChart(const Vector3& x, int ignored) const {
  bool covered = false;
  forChartsNear(x, max_radius_, [&](int i) {
    if (!covered && i != ignored && charts_[static_cast<std::size_t>(i)].ballContains(x)) covered = true;
  });
  return covered;
}

int Atlas::addChart(Chart chart) {
  const int new_index = static_cast<int>(charts_.size());
  drawn_.push_back(chart.candidates);
  // A chart's own candidates lie inside its own ball by construction (annulus within rho),
  // so only the other charts' balls are tested.
  auto& own = chart.candidates;
  own.erase(std::remove_if(own.begin(), own.end(),
                           [&](const ChartCandidate& c) {
                             return coveredByOtherChart(c.ambient, -1);
                           }),
            own.end());
  // A chart's candidates lie within its radius of its centre, so only charts whose centre is
  // within both radii of the new one can lose any.
  forChartsNear(chart.centre, chart.radius + max_radius_, [&](int i) {
    auto& candidates = charts_[static_cast<std::size_t>(i)].candidates;
    candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                    [&](const ChartCandidate& c) { return chart.ballContains(c.ambient); }),
                     candidates.end());
  });
  charts_.push_back(std::move(chart));
  index(new_index);
  return new_index;
}

Atlas Atlas::keep(const Atlas& previous, const std::vector<int>& kept,
                  const std::function<bool(int, const ChartCandidate&)>& restore) {
  Atlas atlas;
  std::vector<int> new_index(previous.size(), -1);
  for (int old : kept) {
    Chart chart = previous.chart(old);
    chart.parent = chart.parent >= 0 ? new_index[static_cast<std::size_t>(chart.parent)] : -1;
    chart.candidates.clear();
    new_index[static_cast<std::size_t>(old)] = static_cast<int>(atlas.size());
    atlas.drawn_.push_back(previous.drawnCandidates(old));
    atlas.charts_.push_back(std::move(chart));
    atlas.index(static_cast<int>(atlas.size()) - 1);
  }
  for (std::size_t k = 0; k < kept.size(); ++k) {
    const int old = kept[k];
    for (const ChartCandidate& candidate : previous.drawnCandidates(old))
      if (restore(old, candidate) && !atlas.coveredByOtherChart(candidate.ambient, static_cast<int>(k)))
        atlas.charts_[k].candidates.push_back(candidate);
  }
  return atlas;
}

void Atlas::removeCandidate(int chart_index, std::size_t candidate_index) {
  auto& candidates = charts_.at(static_cast<std::size_t>(chart_index)).candidates;
  if (candidate_index >= candidates.size()) throw std::out_of_range("Atlas::removeCandidate: no such candidate");
  candidates.erase(candidates.begin() + static_cast<std::ptrdiff_t>(candidate_index));
}

bool Atlas::isExpandable() const {
  return std::any_of(charts_.begin(), charts_.end(), [](const Chart& c) { return c.expandable(); });
}

std::vector<int> Atlas::expandableCharts() const {
  std::vector<int> indices;
  for (std::size_t i = 0; i < charts_.size(); ++i)
    if (charts_[i].expandable()) indices.push_back(static_cast<int>(i));
  return indices;
}

std::vector<int> Atlas::pathTo(int index) const {
  std::vector<int> path;
  if (index < 0 || static_cast<std::size_t>(index) >= charts_.size()) return path;
  // Parents always precede their children, so the walk ends at the root in at most size() steps.
  for (int current = index; current >= 0; current = charts_[static_cast<std::size_t>(current)].parent) {
    path.push_back(current);
    if (path.size() > charts_.size()) throw std::logic_error("Atlas::pathTo: cycle in the chart tree");
  }
  std::reverse(path.begin(), path.end());
  return path;
}

}  // namespace gpatlas_core
