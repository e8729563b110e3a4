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

// A strategy's planning times: every plan's, and those of the plans made on models of about a
// thousand observations (planning time grows with the model's size, and a run's median mixes
// plans made on models of very different sizes).
struct PlanTimes {
  std::string strategy;
  std::vector<double> all_ms, band_ms;
};
std::vector<PlanTimes> planTimesByStrategy(const std::vector<RunResult>& runs);
std::string describePlanTimes(const PlanTimes& p);

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
