// `hrad sweep`: experiments::runSweep with the command-line options.
#include <filesystem>

#include <fmt/format.h>

#include "apps/commands.h"
#include "experiments/sweep.h"

namespace hrad::app {

namespace fs = std::filesystem;

int runSweepCommand(const SweepCliOptions& o) {
    experiments::Study study = experiments::loadStudy(o.study);
    if (o.maxPoints > 0) {
        study.limits.maxPoints = uint64_t(o.maxPoints);
        study.limits.maxPointsWhere = SourceLocation{"command line (--max-points)", 0, 0};
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
    so.store = o.store.empty()
                   ? fs::path(o.study).parent_path() / "results" / (study.name + ".sqlite")
                   : fs::path(o.store);
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
    experiments::SweepReport r = experiments::runSweep(study, so);
    fmt::print("study '{}': {} point(s), {} in this shard, {} skipped (already done), {} finished, "
               "{} failed\nstore: {}\n",
               study.name, r.points, r.selected, r.skipped, r.finished, r.failed, so.store.string());
    return r.failed > 0 ? 3 : 0;
}

}  // namespace hrad::app
