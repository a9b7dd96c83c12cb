// `hrad sweep`: experiments::runSweep with the command-line options.
#include <filesystem>

#include <fmt/format.h>

#include "apps/commands.h"
#include "experiments/sweep.h"

namespace hrad::app {

namespace fs = std::filesystem;

int runSweepCommand(const SweepCliOptions& o) {
    experiments::Study study = experiments::loadStudy(o.study);
    experiments::validateStudy(study);
    if (o.dryRun) {
        fmt::print("{}", experiments::describePoints(study));
        return 0;
    }
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
