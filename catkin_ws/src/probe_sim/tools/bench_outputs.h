#pragma once

// gpatlas_bench's outputs: runs.csv, history.csv, reachability.csv and summary.md.

#include "bench_options.h"
#include "bench_run.h"
#include "bench_truth.h"

#include <filesystem>
#include <string>
#include <vector>

namespace gpatlas_bench {

void writeRunsCsv(const std::vector<RunResult>& runs, const std::filesystem::path& path);
void writeHistoryCsv(const std::vector<RunResult>& runs, const std::filesystem::path& path);
void writeReachabilityCsv(const std::vector<RunResult>& runs, const std::vector<GroundTruth>& objects,
                          const std::filesystem::path& path);

// A strategy's planning and update times: every plan's, and per bin of model size (n_train, the
// observations the plan saw, in bins of kTimeBinObservations): planning time grows with the
// model's size, and a run's median mixes plans made on models of very different sizes.
constexpr std::size_t kTimeBinObservations = 2000;
struct TimeBin {
  std::size_t first_observations{0};  // the bin holds n_train in [first, first + kTimeBinObservations)
  std::vector<double> plan_ms, update_ms;
};
struct PlanTimes {
  std::string strategy;
  std::vector<double> all_ms;
  std::vector<TimeBin> bins;  // by model size, ascending; only bins with a plan
};
std::vector<PlanTimes> planTimesByStrategy(const std::vector<RunResult>& runs);
// One line: the strategy's median plan over all its plans, and its largest bin's.
std::string describePlanTimes(const PlanTimes& p);
// One line per bin: plan and update median / p95 / max.
std::vector<std::string> describeTimeBins(const PlanTimes& p);

// The settings summary.md names: config, overlays, --set, probe, V_max, seeds, max actions, table.
std::string summarySettings(const Options& o);

// Per object and strategy, the means over the runs that left a predicted surface; the planning
// times; and the reachable truth, when it was measured.
// `missing_jobs` (a merge's, MergeResult::missing_jobs) are named under the settings: the
// tables are then not the whole sweep.
void writeSummary(const std::vector<RunResult>& runs, const std::vector<GroundTruth>& truths,
                  const std::vector<PlanTimes>& plan_times, const std::string& settings,
                  const std::filesystem::path& path, const std::vector<std::string>& missing_jobs = {});

// summary.md of the folder, from its runs.csv, history.csv and reachability.csv as written (the
// one path for a run and for a merge of shards, so that both give the same summary); returns
// the planning times it lists. Throws std::runtime_error when a file is missing or malformed.
std::vector<PlanTimes> writeSummaryOfFolder(const std::filesystem::path& folder, const std::string& settings,
                                            const std::vector<std::string>& missing_jobs = {});

}  // namespace gpatlas_bench
