#pragma once

// gpatlas_bench on a cluster: the job list, a shard's share of it (--shard K/N), the shard.txt
// that describes a shard's folder, and the merge of the shards' folders (--merge).

#include "bench_options.h"
#include "bench_truth.h"

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace gpatlas_bench {

// One run of the bench: an object (its index in the command line's order), a strategy, a seed.
struct Job {
  std::size_t object;
  std::string strategy;
  int seed;
};

// Every (object, strategy, seed), in that order: the order of a one-process run's outputs.
std::vector<Job> jobList(std::size_t object_count, const Options& o);

// Whether job `j` of the list belongs to the shard; every job is in exactly one of 1/N ... N/N.
bool inShard(std::size_t j, const Shard& shard);

// shard.txt in `folder`: the shard, the settings that decide the runs (the command line's, a
// fingerprint of the config, overlays, robot and scene files, the summary's settings line) and the
// whole job list, so that a merge can check the shards belong together and name missing jobs.
void writeShardFile(const std::filesystem::path& folder, const Shard& shard, const std::vector<Job>& jobs,
                    const std::vector<GroundTruth>& objects, const Options& o);

struct MergeResult {
  std::string summary_settings;  // the settings line of the shards' summary.md
  std::vector<std::string> missing_jobs;  // "job 7 (mug atlas_poke seed 1, shard 2/3)", in job order
  std::size_t merged_runs{0};
  std::size_t error_runs{0};  // merged runs whose status is an error
};

// Writes into `out` the runs.csv, history.csv and reachability.csv of the shards in `folders`,
// their rows copied as written, in the job list's order. Throws std::runtime_error, writing
// nothing, when a folder or a file is missing, a job is in two shards, the shards' settings
// differ or a shard's files do not match its share of the job list. Jobs no shard ran are
// listed in the result; the runs that are there are merged.
MergeResult mergeShards(const std::vector<std::string>& folders, const std::filesystem::path& out);

}  // namespace gpatlas_bench
