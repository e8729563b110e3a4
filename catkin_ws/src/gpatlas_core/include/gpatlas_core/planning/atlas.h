#pragma once

#include "gpatlas_core/planning/chart.h"

#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

namespace gpatlas_core {

// A tree of coordinated charts over the predicted surface (paper 3.2 and Algorithm 1). Charts
// are kept in creation order; index 0 is the root, every other chart points at its parent.
class Atlas {
 public:
  // Adds a chart and coordinates the atlas (ADDCHART): the new chart loses the candidates that
  // fall inside any existing chart's ball, and every existing chart loses the candidates that
  // fall inside the new chart's ball. Candidates are tested at their ambient tangent points
  // (eq. 12), which is what eq. 16 ranks. Returns the new chart's index.
  int addChart(Chart chart);

  // Removes one candidate of a chart (used once it has been tried by EXPANDCHART).
  void removeCandidate(int chart_index, std::size_t candidate_index);

  const std::vector<Chart>& charts() const { return charts_; }
  const Chart& chart(int index) const { return charts_.at(static_cast<std::size_t>(index)); }
  // For the planner's touch fields (approach_direction, out_of_reach), which the coordination
  // of the atlas does not read.
  Chart& chart(int index) { return charts_.at(static_cast<std::size_t>(index)); }
  // The candidates the chart drew when it was made, before the atlas's coordination took any.
  const std::vector<ChartCandidate>& drawnCandidates(int index) const { return drawn_.at(static_cast<std::size_t>(index)); }
  std::size_t size() const { return charts_.size(); }
  bool empty() const { return charts_.empty(); }

  bool isExpandable() const;
  std::vector<int> expandableCharts() const;
  // The chart indices from the root to `index`, root first (GETPATH).
  std::vector<int> pathTo(int index) const;
  // True if x lies strictly inside the ball of any chart except `ignored`.
  bool coveredByOtherChart(const Vector3& x, int ignored) const;

  // A coordinated atlas of some charts of `previous` (`kept`, indices in ascending order), for a
  // plan that reuses them: their order, a parent left out makes its child a root, and each keeps
  // the candidates it drew that `restore` accepts (old index, candidate) and no kept chart's ball holds.
  static Atlas keep(const Atlas& previous, const std::vector<int>& kept,
                    const std::function<bool(int, const ChartCandidate&)>& restore);

 private:
  using CellKey = std::int64_t;
  CellKey cellOf(const Vector3& x) const;
  // Calls visit(index) for every chart whose centre lies within `reach` of x (and maybe others
  // near it): the cells of the spatial index around x.
  void forChartsNear(const Vector3& x, double reach, const std::function<void(int)>& visit) const;
  void index(int chart_index);

  std::vector<Chart> charts_;
  std::vector<std::vector<ChartCandidate>> drawn_;
  // The charts by the cube of side kCell_m their centre lies in: a plan over a large model holds
  // thousands of charts, and coverage tests against every one of them would cost as much as the
  // queries the reuse saves.
  static constexpr double kCell_m = 0.02;
  std::unordered_map<CellKey, std::vector<int>> cells_;
  double max_radius_{0.0};
};

}  // namespace gpatlas_core
