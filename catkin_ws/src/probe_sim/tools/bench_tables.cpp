#include "bench_tables.h"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

namespace gpatlas_bench {

namespace fs = std::filesystem;

namespace {

// The records of `text`: fields split at commas outside quotes, "" inside quotes is a quote,
// a record ends at a newline outside quotes.
std::vector<CsvRecord> parseRecords(const std::string& text, const fs::path& path) {
  std::vector<CsvRecord> records;
  CsvRecord record;
  std::string field;
  bool quoted = false;
  std::size_t start = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c != '"') field += c;
      else if (i + 1 < text.size() && text[i + 1] == '"') field += text[++i];
      else quoted = false;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      record.fields.push_back(field);
      field.clear();
    } else if (c == '\n') {
      record.fields.push_back(field);
      record.text = text.substr(start, i + 1 - start);
      records.push_back(std::move(record));
      record = CsvRecord();
      field.clear();
      start = i + 1;
    } else {
      field += c;
    }
  }
  if (quoted || start != text.size())
    throw std::runtime_error(path.string() + ": the last record is cut off (an unfinished write?)");
  return records;
}

double number(const std::string& text) { return std::strtod(text.c_str(), nullptr); }

}  // namespace

const std::string& CsvTable::field(const CsvRecord& row, const std::string& column) const {
  const auto it = std::find(header.fields.begin(), header.fields.end(), column);
  if (it == header.fields.end()) throw std::runtime_error(path.string() + ": no column '" + column + "'");
  const auto index = static_cast<std::size_t>(it - header.fields.begin());
  if (index >= row.fields.size()) throw std::runtime_error(path.string() + ": a row without column '" + column + "'");
  return row.fields[index];
}

CsvTable readCsv(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("missing file " + path.string());
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::vector<CsvRecord> records = parseRecords(text, path);
  if (records.empty()) throw std::runtime_error(path.string() + ": empty, not even a header");
  CsvTable table;
  table.path = path;
  table.header = std::move(records.front());
  table.rows.assign(std::make_move_iterator(records.begin() + 1), std::make_move_iterator(records.end()));
  for (std::size_t i = 0; i < table.rows.size(); ++i)
    if (table.rows[i].fields.size() != table.header.fields.size())
      throw std::runtime_error(path.string() + ": row " + std::to_string(i + 1) + " has " +
                               std::to_string(table.rows[i].fields.size()) + " fields, the header " +
                               std::to_string(table.header.fields.size()));
  return table;
}

std::string BenchTables::key(const RunRows& run) const {
  return runs.field(run.run, "object") + " " + runs.field(run.run, "strategy") + " seed " + runs.field(run.run, "seed");
}

BenchTables readBenchTables(const fs::path& folder) {
  BenchTables t;
  t.runs = readCsv(folder / "runs.csv");
  t.history = readCsv(folder / "history.csv");
  t.reachability = readCsv(folder / "reachability.csv");
  auto keyOf = [](const CsvTable& table, const CsvRecord& row) {
    return table.field(row, "object") + " " + table.field(row, "strategy") + " seed " + table.field(row, "seed");
  };
  // Each file lists the runs in runs.csv's order; a run's history starts at action 0.
  std::size_t h = 0, r = 0;
  for (const CsvRecord& run : t.runs.rows) {
    RunRows rows;
    rows.run = run;
    const std::string key = keyOf(t.runs, run);
    while (h < t.history.rows.size() && keyOf(t.history, t.history.rows[h]) == key &&
           (rows.history.empty() || t.history.field(t.history.rows[h], "action") != "0"))
      rows.history.push_back(t.history.rows[h++]);
    if (r < t.reachability.rows.size() && keyOf(t.reachability, t.reachability.rows[r]) == key)
      rows.reachability = t.reachability.rows[r++];
    t.by_run.push_back(std::move(rows));
  }
  if (h < t.history.rows.size())
    throw std::runtime_error(t.history.path.string() + ": row " + std::to_string(h + 1) + " (" +
                             keyOf(t.history, t.history.rows[h]) + ") follows no run of runs.csv in order");
  if (r < t.reachability.rows.size())
    throw std::runtime_error(t.reachability.path.string() + ": row " + std::to_string(r + 1) + " (" +
                             keyOf(t.reachability, t.reachability.rows[r]) + ") follows no run of runs.csv in order");
  return t;
}

void runsFromTables(const BenchTables& t, std::vector<RunResult>* runs, std::vector<GroundTruth>* truths) {
  // Files of a bench without the F-score's column read as not measured there.
  const auto& history_columns = t.history.header.fields;
  const bool has_fscore = std::find(history_columns.begin(), history_columns.end(), "fscore_5mm") != history_columns.end();
  for (const RunRows& rows : t.by_run) {
    const auto& run = [&](const std::string& column) -> const std::string& { return t.runs.field(rows.run, column); };
    RunResult r;
    r.object = run("object");
    r.strategy = run("strategy");
    r.probe = run("probe");
    r.seed = std::atoi(run("seed").c_str());
    r.status = run("status");
    r.stop_reason = run("stop_reason");
    r.actions = std::atoi(run("actions").c_str());
    r.converged = run("converged") == "1";
    // The bench writes the shape metrics as nan exactly when the run left no surface to measure.
    r.metrics.ok = run("rmse_pred_to_gt_m") != "nan";
    r.metrics.rmse_predicted_to_truth = number(run("rmse_pred_to_gt_m"));
    r.metrics.rmse_truth_to_predicted = number(run("rmse_gt_to_pred_m"));
    r.metrics.chamfer_l1 = number(run("chamfer_l1_m"));
    r.metrics.f_score = number(run("fscore_5mm"));
    r.calibration = number(run("calibration_2sd"));
    r.position_sd_m = number(run("position_sd_m"));
    r.coverage = number(run("coverage_2sd"));
    r.sharpness = number(run("sharpness"));
    r.position_sd_scale = number(run("position_sd_scale"));
    for (const CsvRecord& h : rows.history) {
      gpatlas_core::ExplorationRecord record;
      record.index = std::atoi(t.history.field(h, "action").c_str()) - 1;
      record.plan_ms = number(t.history.field(h, "plan_ms"));
      record.update_ms = number(t.history.field(h, "update_ms"));
      record.n_train = static_cast<std::size_t>(std::strtoull(t.history.field(h, "n_train").c_str(), nullptr, 10));
      record.contacts_total = std::atoi(t.history.field(h, "contacts_total").c_str());
      record.rmse_pred_to_gt_m = number(t.history.field(h, "rmse_pred_to_gt_m"));
      record.rmse_gt_to_pred_m = number(t.history.field(h, "rmse_gt_to_pred_m"));
      if (has_fscore) record.fscore_5mm = number(t.history.field(h, "fscore_5mm"));
      r.history.push_back(record);
    }
    if (rows.reachability) {
      const CsvRecord& reach = *rows.reachability;
      r.rmse_gt_to_pred_reachable = number(t.reachability.field(reach, "rmse_gt_to_pred_reachable_m"));
      if (std::none_of(truths->begin(), truths->end(), [&](const GroundTruth& g) { return g.name == r.object; })) {
        GroundTruth gt;
        gt.name = r.object;
        gt.reachability_measured = true;
        gt.reachable_area_fraction = number(t.reachability.field(reach, "reachable_area_fraction"));
        gt.floor_rmse_gt_to_pred = number(t.reachability.field(reach, "floor_rmse_gt_to_pred_m"));
        truths->push_back(std::move(gt));
      }
    }
    runs->push_back(std::move(r));
  }
}

}  // namespace gpatlas_bench
