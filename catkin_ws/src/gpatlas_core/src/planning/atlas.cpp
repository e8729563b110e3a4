#include "gpatlas_core/planning/atlas.h"

#include <algorithm>
#include <stdexcept>

namespace gpatlas_core {

bool Atlas::coveredByOtherChart(const Vector3& x, int ignored) const {
  for (std::size_t i = 0; i < charts_.size(); ++i)
    if (static_cast<int>(i) != ignored && charts_[i].ballContains(x)) return true;
  return false;
}

int Atlas::addChart(Chart chart) {
  const int new_index = static_cast<int>(charts_.size());
  // A chart's own candidates lie inside its own ball by construction (annulus within rho),
  // so only the other charts' balls are tested.
  auto& own = chart.candidates;
  own.erase(std::remove_if(own.begin(), own.end(),
                           [&](const ChartCandidate& c) {
                             return coveredByOtherChart(c.ambient, -1);
                           }),
            own.end());
  for (Chart& existing : charts_) {
    auto& candidates = existing.candidates;
    candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                    [&](const ChartCandidate& c) {
                                      return chart.ballContains(c.ambient);
                                    }),
                     candidates.end());
  }
  charts_.push_back(std::move(chart));
  return new_index;
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
