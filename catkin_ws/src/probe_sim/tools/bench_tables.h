#pragma once

// gpatlas_bench's CSV files read back: the rows of runs.csv, history.csv and reachability.csv
// grouped by run. The merge of shards copies these rows as written, and summary.md is always
// computed from them, so that a merge's summary and a one-process run's are the same.

#include "bench_run.h"
#include "bench_truth.h"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_bench {

// One CSV record: its fields, and its text as written (with its line end), to copy unchanged.
struct CsvRecord {
  std::vector<std::string> fields;
  std::string text;
};

struct CsvTable {
  std::filesystem::path path;
  CsvRecord header;
  std::vector<CsvRecord> rows;
  // The field `column` of `row`; throws when the header has no such column.
  const std::string& field(const CsvRecord& row, const std::string& column) const;
};

// The file; throws std::runtime_error when it is missing or a record is malformed.
CsvTable readCsv(const std::filesystem::path& path);

// One run's rows: its row of runs.csv, its rows of history.csv (action 0 first) and its row of
// reachability.csv, if its object's reachability was measured.
struct RunRows {
  CsvRecord run;
  std::vector<CsvRecord> history;
  std::optional<CsvRecord> reachability;
};

// The three files of a bench output folder.
struct BenchTables {
  CsvTable runs, history, reachability;
  std::vector<RunRows> by_run;  // in runs.csv's order
  // The run's object, strategy and seed, as runs.csv has them.
  std::string key(const RunRows& run) const;
};

// The folder's runs.csv, history.csv and reachability.csv; throws std::runtime_error when one
// is missing or has rows that belong to no run of runs.csv.
BenchTables readBenchTables(const std::filesystem::path& folder);

// The runs as far as summary.md needs them (identity, status, actions, shape metrics, the
// reachable truth's RMSE; per action the plan time, model size, contacts and shape error), and
// the truths whose reachability was measured (name, reachable share, floor), in the order of
// their first run.
void runsFromTables(const BenchTables& tables, std::vector<RunResult>* runs, std::vector<GroundTruth>* truths);

}  // namespace gpatlas_bench
