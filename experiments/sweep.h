// Running a study: every selected point in its own child process.
//
// Isolation. The parent never loads a scene or starts a thread pool; for each
// point it fork()s a child that sets its limits (RLIMIT_AS for --max-memory,
// alarm() for --max-seconds), runs experiments::runPoint, writes its summary
// (or its exception) to a file and _exit()s. The parent reaps children with
// wait4(), which also yields each child's own peak RSS (ru_maxrss), and writes
// the result into the store: a run row in its own transaction, or a failure
// row ("error", "input", "timeout", "memory", "signal") with its message.
// A child's peak RSS includes the pages it shares with the parent at fork
// time (a few MiB: the parent holds no scene).
//
// Resume. Points are keyed by experiments::pointKey; points whose key has a
// run row (and, unless retryFailed, a failure row) are skipped. A sweep that
// is killed loses only the points running at that moment. A child ended by
// SIGTERM, SIGINT or SIGHUP (scancel, a Slurm time limit, Ctrl-C: the whole
// process group is signalled) is not recorded as a failure: the point stays
// missing and reruns on resume.
//
// Parallelism: `jobs` children at once; each gets max(1, cores / jobs) TBB
// threads unless `threads` is set. Sharding: point i is run by shard
// (i mod N) only. References: before the points, every distinct (scene,
// reference settings) of the selected points is computed once in a child
// (through the on-disk cache) so that point children only read the cache.
// A point list (--points-file) restricts the sweep to those indices (the
// points a Slurm resubmission runs); referencesOnly stops after the
// references (the references job of a Slurm pipeline).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "experiments/study.h"

namespace hrad::experiments {

/// --max-seconds: finite, 0 (none) to a year; throws InputError naming it.
double checkMaxSeconds(double seconds);

struct SweepOptions {
    std::filesystem::path store;
    int jobs = 1;
    int shardIndex = 0, shardCount = 1;  ///< --shard i/N, 0 <= i < N
    bool resume = false;       ///< required to continue into a store that has runs
    bool retryFailed = false;  ///< rerun points recorded as failures
    double maxSeconds = 0.0;   ///< per point; 0: study's [limits] or none
    uint64_t maxMemoryBytes = 0;
    int threads = 0;           ///< per child; 0: cores / jobs
    bool progress = false;     ///< progress bars of children on stderr
    std::string cacheDir;      ///< reference cache ("" = default)
    bool useCache = true;
    /// Point indices to run ("--points-file"); empty: every point. With a
    /// list, --shard i/N selects the list's entries at positions p % N == i.
    std::vector<uint64_t> pointList;
    /// Compute the selected points' references into the cache and stop: no
    /// store is opened (the first job of a Slurm pipeline, experiments/slurm.h).
    bool referencesOnly = false;
    /// Test hook, called in the parent after each point is committed
    /// (ok = run row, else failure row).
    std::function<void(const PointSpec&, bool ok)> onPointDone;
};

struct SweepReport {
    size_t points = 0;     ///< in the study
    size_t selected = 0;   ///< in this shard
    size_t skipped = 0;    ///< already in the store
    size_t finished = 0;   ///< run rows written now
    size_t failed = 0;     ///< failure rows written now
    size_t references = 0;         ///< distinct references prepared (computed or found cached)
    size_t referencesFailed = 0;   ///< of which failed
};

/// Validates the whole study first (validateStudy), then runs the selected
/// points. Throws InputError for an invalid study, Error when the store has
/// runs and resume is false.
SweepReport runSweep(const Study& study, const SweepOptions& options);

/// "i/N" -> (i, N); throws InputError.
std::pair<int, int> parseShard(const std::string& text);
/// Reads a point list file: indices (0-based, < study.pointCount()) separated
/// by whitespace or commas, '#' starts a comment. Throws InputError with
/// FILE:LINE for a bad or out-of-range index or a duplicate.
std::vector<uint64_t> readPointList(const std::filesystem::path& file, const Study& study);
/// "512M", "4G", "1T", "1000000" -> bytes, 1 MiB to 2^60; throws InputError.
uint64_t parseBytes(const std::string& text);

}  // namespace hrad::experiments
