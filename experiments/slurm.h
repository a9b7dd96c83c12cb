// A study on a Slurm cluster: `hrad sweep STUDY --slurm` writes a pipeline
// of three batch jobs into a folder and, unless --dry-run, submits it with
// sbatch. The scheduler is Slurm's; hrad only writes plain scripts a user can
// read and edit, and a submit.sh that chains them:
//
//   references.sbatch  `hrad sweep STUDY --references-only --cache CACHE`:
//                      every distinct (scene, reference settings) of the
//                      points is computed once into the reference cache, a
//                      folder every node sees (experiments/sweep.h).
//   points.sbatch      a job array `--array=0-(N-1)%P`; task i runs
//                      `hrad sweep STUDY --shard i/N --store shards/task-i.sqlite`
//                      (points p with p % N == i) with
//                      `--dependency=afterok:<references>`. Each point is
//                      committed to the task's shard store when it finishes,
//                      so a task killed by scancel, a time limit or a node
//                      failure loses only the point it was running.
//   merge.sbatch       afterany on the array: `hrad results merge STORE
//                      shards/*.sqlite`, then `hrad sweep STUDY --status`,
//                      which writes report.txt (finished, failed and missing
//                      points) and exits 4 when points are missing.
//   submit.sh          sbatch --parsable of the three, chaining the job ids;
//                      the ids go to jobs.txt.
//
// `hrad sweep STUDY --slurm --resume` merges the shard stores into the store,
// computes the points without a run row (point keys, experiments::pointKey;
// failed points too with --retry-failed), writes them to resume-K/points.txt
// and submits the same three jobs over that list only (`--points-file`; the
// array's shards split the list). It refuses while a job of an earlier round
// is still queued or running (squeue).
//
// Settings: the study's [slurm] table, overridden by `--slurm-set key=value`.
//   partition      string  ""   #SBATCH --partition; "" = the cluster's default
//   account        string  ""   #SBATCH --account
//   time           string  derived  time limit per array task: minutes
//                               (integer) or Slurm's MM:SS, HH:MM:SS, D-HH,
//                               D-HH:MM, D-HH:MM:SS. Default: with [limits]
//                               max_seconds = s, ceil(points per task) * s
//                               plus 10 % plus 10 min (start-up, reading the
//                               cached reference, store writes); without it,
//                               no --time (the partition's default).
//   mem            string  derived  memory per task: MB (integer) or Slurm's
//                               size (4000M, 4G). Default: [limits]
//                               max_memory_mb + 512 MB (the sweep's parent
//                               process and SQLite beside the point's child);
//                               without it, no --mem.
//   cpus           int     1    #SBATCH --cpus-per-task and the threads of
//                               each point (hrad --threads)
//   tasks          int     0    array tasks N; 0 = one per point, at most
//                               1000 (Slurm's default MaxArraySize is 1001)
//   max_parallel   int     0    P in --array=0-(N-1)%P; 0 = no limit
//   sbatch         [string] []  extra #SBATCH lines of all three jobs
//                               ("--qos=long", "--constraint=avx2")
//   reference_time string  ""   --time of the references job ("" = default)
//   reference_mem  string  ""   --mem of the references job ("" = default)
//   reference_cpus int     0    CPUs of the references job; 0 = cpus
//   merge_time     string  ""   --time of the merge job ("" = default)
//   cache          string  ""   reference cache folder on the shared file
//                               system; "" = <dir>/cache (hrad sweep --cache
//                               overrides)
//   dir            string  ""   the pipeline's folder; "" = <store>.slurm
//                               (hrad sweep --slurm-dir overrides)
//   job_name       string  "hrad-<study name>"  prefix of the job names
// Relative cache and dir in the study resolve against the study's folder.
// Values are checked where read; names and lines that end up in #SBATCH
// lines may not contain newlines or shell quoting.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/params.h"
#include "experiments/study.h"

namespace hrad::experiments {

struct SlurmSettings {
    std::string partition, account;
    std::string time;  ///< "" = derived from [limits] max_seconds (or none)
    std::string mem;   ///< "" = derived from [limits] max_memory_mb (or none)
    int cpus = 1;
    int tasks = 0;        ///< 0 = one per point, at most kMaxArrayTasks
    int maxParallel = 0;  ///< 0 = no %P
    std::vector<std::string> extra;  ///< extra #SBATCH lines
    std::string referenceTime, referenceMem;
    int referenceCpus = 0;  ///< 0 = cpus
    std::string mergeTime;
    std::string cache, dir;  ///< as written ("" = default)
    SourceLocation cacheWhere, dirWhere;
    std::string jobName;  ///< "" = hrad-<study name>
};

/// Slurm's default MaxArraySize is 1001: array indices 0..1000.
inline constexpr int kMaxArrayTasks = 1000;

/// Reads and checks every key (see above), then reports unused keys: an
/// InputError with the key's file:line.
SlurmSettings slurmSettingsFromParams(const Params& params);

/// Slurm time syntax -> seconds: "90" (minutes), "MM:SS", "HH:MM:SS", "D-HH",
/// "D-HH:MM", "D-HH:MM:SS". -1 when malformed.
int64_t parseSlurmTime(const std::string& text);
/// Seconds -> "HH:MM:SS" (or "D-HH:MM:SS" from one day on), rounded up to
/// whole minutes (Slurm's resolution).
std::string formatSlurmTime(int64_t seconds);

/// One submission round: the first (every point) or a resubmission.
struct SlurmRound {
    std::filesystem::path binary;     ///< the hrad executable (absolute)
    std::filesystem::path study;      ///< the study file (absolute)
    std::filesystem::path store;      ///< the merged store (absolute)
    std::filesystem::path dir;        ///< the pipeline folder (absolute)
    std::filesystem::path cache;      ///< reference cache (absolute)
    std::filesystem::path scriptDir;  ///< dir, or dir/resume-K
    std::string shardPrefix = "task"; ///< shards/<prefix>-<i>.sqlite
    std::filesystem::path pointsFile; ///< "" = every point of the study
    uint64_t points = 0;              ///< points this round runs
    size_t references = 0;            ///< distinct references (0: no references job)
};

struct SlurmScripts {
    std::string references;  ///< "" when the round has no reference
    std::string points, merge, submit;
};

/// The text of the four files (pure: writes nothing). Array tasks:
/// min(points, settings.tasks or kMaxArrayTasks).
SlurmScripts makeSlurmScripts(const Study& study, const SlurmSettings& settings,
                              const SlurmRound& round);
/// Number of array tasks for `points` points.
int slurmTaskCount(const SlurmSettings& settings, uint64_t points);

/// What a store holds of a study, by point key.
struct StoreStatus {
    uint64_t points = 0;
    uint64_t finished = 0;
    struct Failed {
        uint64_t index;
        std::string kind, message;
    };
    std::vector<Failed> failed;     ///< failure row, no run row
    std::vector<uint64_t> missing;  ///< neither
};
/// Compares the study's point keys with the store's runs and failures (a
/// store that does not exist holds nothing).
StoreStatus storeStatus(const Study& study, const std::filesystem::path& store);
/// "study 'x': 8 point(s): 7 finished, 0 failed, 1 missing" and one line per
/// failed and per missing point.
std::string describeStatus(const Study& study, const StoreStatus& status);

struct SlurmOptions {
    std::filesystem::path store;   ///< the merged store
    std::filesystem::path dir;     ///< --slurm-dir ("" = settings or <store>.slurm)
    std::string cacheDir;          ///< --cache ("" = settings or <dir>/cache)
    Params overrides;              ///< --slurm-set key=value
    bool dryRun = false;           ///< write the scripts, submit nothing
    bool resume = false;           ///< only the points missing from the store
    bool retryFailed = false;      ///< with resume: failed points too
    std::filesystem::path binary;  ///< "" = this executable (/proc/self/exe)
};

/// `hrad sweep STUDY --slurm`: writes (and submits) a round; prints what it
/// did. Returns the exit code (0). Throws InputError for bad settings and
/// Error when submission fails or earlier jobs still run.
int runSlurm(const Study& study, const SlurmOptions& options);

}  // namespace hrad::experiments
