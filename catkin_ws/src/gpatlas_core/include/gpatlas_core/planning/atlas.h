#pragma once

#include "gpatlas_core/planning/chart.h"

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
  std::size_t size() const { return charts_.size(); }
  bool empty() const { return charts_.empty(); }

  bool isExpandable() const;
  std::vector<int> expandableCharts() const;
  // The chart indices from the root to `index`, root first (GETPATH).
  std::vector<int> pathTo(int index) const;
  // True if x lies strictly inside the ball of any chart except `ignored`.
  bool coveredByOtherChart(const Vector3& x, int ignored) const;

 private:
  std::vector<Chart> charts_;
};

}  // namespace gpatlas_core
