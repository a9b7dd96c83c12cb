// `hrad sweep`: experiments::runSweep with the command-line options; with
// --status the store's finished / failed / missing points; with --slurm the
// Slurm pipeline (experiments/slurm.h).
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "apps/commands.h"
#include "core/safe_file.h"
#include "experiments/slurm.h"
#include "experiments/sweep.h"

namespace hrad::app {

namespace fs = std::filesystem;

int runSweepCommand(const SweepCliOptions& o) {
    // Every numeric option is checked first, whatever the mode (--dry-run and
    // --status used to return before reading them: issue 64).
    if (!o.shard.empty()) experiments::parseShard(o.shard);
    experiments::checkMaxSeconds(o.maxSeconds);
    if (!o.maxMemory.empty()) experiments::parseBytes(o.maxMemory);
    experiments::Study study = experiments::loadStudy(o.study);
    if (o.maxPoints > 0) {
        study.limits.maxPoints = uint64_t(o.maxPoints);
        study.limits.maxPointsWhere = SourceLocation{"command line (--max-points)", 0, 0};
    }
    fs::path store = o.store.empty()
                         ? fs::path(o.study).parent_path() / "results" / (study.name + ".sqlite")
                         : fs::path(o.store);
    if (o.status) {
        experiments::checkPointCount(study);
        experiments::StoreStatus st = experiments::storeStatus(study, store);
        std::string text = experiments::describeStatus(study, st) + fmt::format("store: {}\n", store.string());
        fmt::print("{}", text);
        if (!o.report.empty()) writeFileSafely(o.report, text);
        return !st.missing.empty() ? 4 : !st.failed.empty() ? 3 : 0;
    }
    if (o.slurm) {
        if (!o.shard.empty() || !o.pointsFile.empty() || o.referencesOnly)
            throwInputError({"command line (--slurm)", 0, 0},
                            "--slurm writes its own --shard, --points-file and --references-only "
                            "jobs; do not combine them");
        if (o.noCache || o.maxSeconds > 0 || !o.maxMemory.empty() || o.jobs != 1)
            throwInputError({"command line (--slurm)", 0, 0},
                            "--no-cache, --max-seconds, --max-memory and --jobs do not reach the "
                            "Slurm jobs: set [limits] in the study, and [slurm] cpus / tasks "
                            "(or --slurm-set) for the jobs");
        experiments::validateStudy(study);
        experiments::SlurmOptions so;
        so.store = store;
        so.dir = o.slurmDir;
        so.cacheDir = o.cacheDir;
        for (const std::string& kv : o.slurmSets) {
            auto eq = kv.find('=');
            if (eq == std::string::npos || eq == 0)
                throwInputError({"command line (--slurm-set)", 0, 0}, "expected KEY=VALUE, got '{}'", kv);
            so.overrides.setFromText(kv.substr(0, eq), kv.substr(eq + 1),
                                     SourceLocation{"command line (--slurm-set " + kv + ")", 0, 0});
        }
        so.dryRun = o.dryRun;
        so.resume = o.resume;
        so.retryFailed = o.retryFailed;
        return experiments::runSlurm(study, so);
    }
    if (o.dryRun) {
        // Streams: each point is built, validated and printed in turn, so a
        // large study (within sweep.max_points) never sits in memory whole.
        experiments::checkPointCount(study);
        fmt::print("study '{}': {} point(s)\n", study.name, study.pointCount());
        for (uint64_t i = 0; i < study.pointCount(); ++i) {
            experiments::PointSpec p = study.point(i);
            experiments::validateStudyPoint(study, p);
            fmt::print("{}", experiments::describePoint(p));
        }
        return 0;
    }
    experiments::validateStudy(study);
    experiments::SweepOptions so;
    so.store = store;
    so.jobs = o.jobs;
    if (!o.shard.empty()) std::tie(so.shardIndex, so.shardCount) = experiments::parseShard(o.shard);
    so.resume = o.resume;
    so.retryFailed = o.retryFailed;
    so.maxSeconds = o.maxSeconds;
    if (!o.maxMemory.empty()) so.maxMemoryBytes = experiments::parseBytes(o.maxMemory);
    so.threads = o.threads;
    so.progress = o.progress;
    so.cacheDir = o.cacheDir;
    so.useCache = !o.noCache;
    if (!o.pointsFile.empty()) so.pointList = experiments::readPointList(o.pointsFile, study);
    so.referencesOnly = o.referencesOnly;
    experiments::SweepReport r = experiments::runSweep(study, so);
    if (o.referencesOnly) {
        fmt::print("study '{}': {} distinct reference(s) of {} point(s), {} failed\ncache: {}\n",
                   study.name, r.references, r.selected, r.referencesFailed,
                   so.cacheDir.empty() ? "(default)" : so.cacheDir);
        return r.referencesFailed > 0 ? 3 : 0;
    }
    fmt::print("study '{}': {} point(s), {} in this shard, {} skipped (already done), {} finished, "
               "{} failed\nstore: {}\n",
               study.name, r.points, r.selected, r.skipped, r.finished, r.failed, so.store.string());
    return r.failed > 0 ? 3 : 0;
}

}  // namespace hrad::app
