#include "bench_shards.h"

#include "bench_outputs.h"
#include "bench_tables.h"

#include <cstdint>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

namespace gpatlas_bench {

namespace fs = std::filesystem;

namespace {

constexpr const char* kShardFile = "shard.txt";
constexpr const char* kShardLine = "gpatlas_bench shard ";

// FNV-1a of the files' contents: shards reading different configs under the same path differ.
std::string fingerprint(const std::vector<std::string>& texts) {
  std::uint64_t hash = 1469598103934665603ULL;
  for (const std::string& text : texts)
    for (unsigned char c : text + '\0') hash = (hash ^ c) * 1099511628211ULL;
  std::ostringstream s;
  s << std::hex << hash;
  return s.str();
}

std::string fileText(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// A shard's folder as the merge reads it.
struct ShardFolder {
  fs::path folder;
  Shard shard;
  std::vector<std::string> settings;  // every line of shard.txt but the first: equal in all shards
  std::string summary_settings;
  std::vector<std::string> job_names;  // the whole job list's
  BenchTables tables;
};

Shard parseShardLine(const std::string& line, const fs::path& file) {
  std::istringstream s(line.substr(std::string(kShardLine).size()));
  Shard shard;
  char slash = 0;
  if (line.rfind(kShardLine, 0) != 0 || !(s >> shard.index >> slash >> shard.count) || slash != '/' ||
      shard.index < 1 || shard.index > shard.count)
    throw std::runtime_error(file.string() + ": not a gpatlas_bench shard file (first line '" + line + "')");
  return shard;
}

ShardFolder readShardFolder(const std::string& folder) {
  ShardFolder s;
  s.folder = folder;
  if (!fs::is_directory(s.folder)) throw std::runtime_error("missing folder " + folder);
  const fs::path file = s.folder / kShardFile;
  std::ifstream f(file);
  if (!f) throw std::runtime_error("missing file " + file.string() + " (gpatlas_bench --shard K/N writes it last, "
                                   "when the shard's runs are done)");
  std::string line;
  std::getline(f, line);
  s.shard = parseShardLine(line, file);
  while (std::getline(f, line)) {
    s.settings.push_back(line);
    if (line.rfind("summary ", 0) == 0) s.summary_settings = line.substr(8);
    if (line.rfind("job ", 0) == 0) s.job_names.push_back(line.substr(line.find(' ', 4) + 1));
  }
  s.tables = readBenchTables(s.folder);
  return s;
}

// The shard's runs.csv holds its share of the job list, in order.
void checkShareOfJobs(const ShardFolder& s) {
  std::vector<std::size_t> share;
  for (std::size_t j = 0; j < s.job_names.size(); ++j)
    if (inShard(j, s.shard)) share.push_back(j);
  const std::string where = (s.folder / "runs.csv").string();
  if (s.tables.by_run.size() != share.size())
    throw std::runtime_error(where + ": " + std::to_string(s.tables.by_run.size()) + " runs, but shard " +
                             std::to_string(s.shard.index) + "/" + std::to_string(s.shard.count) + " of " +
                             std::to_string(s.job_names.size()) + " jobs has " + std::to_string(share.size()));
  for (std::size_t i = 0; i < share.size(); ++i)
    if (s.tables.key(s.tables.by_run[i]) != s.job_names[share[i]])
      throw std::runtime_error(where + ": run " + std::to_string(i + 1) + " is " + s.tables.key(s.tables.by_run[i]) +
                               ", but the shard's job " + std::to_string(share[i]) + " is " + s.job_names[share[i]]);
}

void checkSameSettings(const ShardFolder& first, const ShardFolder& other) {
  std::size_t i = 0;
  while (i < first.settings.size() && i < other.settings.size() && first.settings[i] == other.settings[i]) ++i;
  if (i == first.settings.size() && i == other.settings.size()) {
    if (first.tables.runs.header.text != other.tables.runs.header.text ||
        first.tables.history.header.text != other.tables.history.header.text ||
        first.tables.reachability.header.text != other.tables.reachability.header.text)
      throw std::runtime_error(first.folder.string() + " and " + other.folder.string() +
                               " were written by different gpatlas_bench versions (their CSV columns differ)");
    return;
  }
  auto lineOf = [&](const ShardFolder& s) { return i < s.settings.size() ? "'" + s.settings[i] + "'" : "nothing"; };
  throw std::runtime_error("the shards were run with different settings: " + first.folder.string() + "/" + kShardFile +
                           " has " + lineOf(first) + " where " + other.folder.string() + "/" + kShardFile + " has " +
                           lineOf(other));
}

void writeRows(const fs::path& path, const CsvRecord& header, const std::vector<const CsvRecord*>& rows) {
  std::ofstream f(path, std::ios::binary);
  f << header.text;
  for (const CsvRecord* row : rows) f << row->text;
  if (!f) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

std::vector<Job> jobList(std::size_t object_count, const Options& o) {
  std::vector<Job> jobs;
  for (std::size_t i = 0; i < object_count; ++i)
    for (const auto& s : o.strategies)
      for (int seed : o.seeds) jobs.push_back({i, s, seed});
  return jobs;
}

bool inShard(std::size_t j, const Shard& shard) {
  return j % static_cast<std::size_t>(shard.count) == static_cast<std::size_t>(shard.index - 1);
}

void writeShardFile(const fs::path& folder, const Shard& shard, const std::vector<Job>& jobs,
                    const std::vector<GroundTruth>& objects, const Options& o) {
  // Everything read from a file that decides the runs: a scene (--simulation) edited between two
  // shards under the same path made two sweeps that merged as one.
  std::vector<std::string> files{fileText(o.config_path)};
  for (const std::string& overlay : o.overlays) files.push_back(fileText(overlay));
  files.push_back(o.urdf_xml);
  files.push_back(fileText(o.simulation_path));
  std::ofstream f(folder / kShardFile);
  f << kShardLine << shard.index << '/' << shard.count << '\n';
  for (const std::string& arg : o.result_args) f << "arg " << arg << '\n';
  f << "files " << fingerprint(files) << '\n';
  f << "summary " << summarySettings(o) << '\n';
  f << "jobs " << jobs.size() << '\n';
  for (std::size_t j = 0; j < jobs.size(); ++j)
    f << "job " << j << ' ' << objects[jobs[j].object].name << ' ' << jobs[j].strategy << " seed " << jobs[j].seed
      << '\n';
  if (!f) throw std::runtime_error("cannot write " + (folder / kShardFile).string());
}

MergeResult mergeShards(const std::vector<std::string>& folders, const fs::path& out) {
  std::vector<ShardFolder> shards;
  for (const std::string& folder : folders) {
    shards.push_back(readShardFolder(folder));
    checkShareOfJobs(shards.back());
    checkSameSettings(shards.front(), shards.back());
    std::error_code ec;
    if (fs::exists(out) && fs::equivalent(out, shards.back().folder, ec))
      throw std::runtime_error("--out " + out.string() + " is one of the shards' folders; merge into another");
  }
  const std::size_t job_count = shards.front().job_names.size();
  std::vector<const RunRows*> by_job(job_count, nullptr);
  std::vector<const ShardFolder*> source(job_count, nullptr);
  for (const ShardFolder& s : shards) {
    std::size_t next_run = 0;
    for (std::size_t j = 0; j < job_count; ++j) {
      if (!inShard(j, s.shard)) continue;
      if (source[j])
        throw std::runtime_error("job " + std::to_string(j) + " (" + s.job_names[j] + ") is present twice: in " +
                                 source[j]->folder.string() + " and in " + s.folder.string());
      by_job[j] = &s.tables.by_run[next_run++];
      source[j] = &s;
    }
  }
  MergeResult result;
  result.summary_settings = shards.front().summary_settings;
  std::vector<const CsvRecord*> runs, history, reachability;
  const CsvTable& columns = shards.front().tables.runs;
  for (std::size_t j = 0; j < job_count; ++j) {
    if (!by_job[j]) {
      const Shard& any = shards.front().shard;
      result.missing_jobs.push_back("job " + std::to_string(j) + " (" + shards.front().job_names[j] + ", shard " +
                                    std::to_string(j % static_cast<std::size_t>(any.count) + 1) + "/" +
                                    std::to_string(any.count) + ")");
      continue;
    }
    runs.push_back(&by_job[j]->run);
    for (const CsvRecord& h : by_job[j]->history) history.push_back(&h);
    if (by_job[j]->reachability) reachability.push_back(&*by_job[j]->reachability);
    if (columns.field(by_job[j]->run, "status").rfind("error", 0) == 0) ++result.error_runs;
  }
  result.merged_runs = runs.size();
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) throw std::runtime_error("cannot create output folder '" + out.string() + "': " + ec.message());
  writeRows(out / "runs.csv", columns.header, runs);
  writeRows(out / "history.csv", shards.front().tables.history.header, history);
  writeRows(out / "reachability.csv", shards.front().tables.reachability.header, reachability);
  return result;
}

}  // namespace gpatlas_bench
