// `hrad reference SCENE --kind full-matrix|montecarlo [--set fm.level=4 ...]`:
// computes a reference through the on-disk cache (reference/cache.h), or
// finds it there, and prints where it is cached.
#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "core/interrupt.h"
#include "experiments/runner.h"

namespace hrad::app {

int runReference(const ReferenceCliOptions& o, Params& params) {
    experiments::PointSpec point;
    point.scene = o.scene;
    point.sceneLabel = o.scene;
    point.reference.set("kind", o.kind, {"command line (--kind)", 0, 0});
    // fm.* and mc.* are the reference's; everything else goes to the loader.
    for (const auto& [k, e] : params.entries()) {
        if (k.rfind("fm.", 0) == 0 || k.rfind("mc.", 0) == 0)
            point.reference.set(k, e.value, e.where);
        else
            point.settings.set(k, e.value, e.where);
    }
    experiments::validatePoint(point);
    experiments::RunContext ctx;
    ctx.cacheDir = o.cacheDir;
    ctx.progress = o.progress;
    // Ctrl-C or SIGTERM: the solver stops at its next row, shot or region;
    // a partial reference is reported, never cached; exit 128 + signal.
    catchInterrupts();
    nlohmann::json r = experiments::prepareReference(point, ctx);
    if (const int sig = interruptSignal(); sig != 0 || r.value("interrupted", false)) {
        fmt::print("interrupted reference for {}: {}\nstats: {}\nnot cached (interrupted: true)\n", o.scene,
                   r.value("reference", ""), r["stats"].dump());
        fmt::print(stderr, "hrad: interrupted by signal {}: the reference is incomplete and was not cached\n", sig);
        return 128 + sig;
    }
    fmt::print("{} reference for {}: {}\n", r.value("cached", false) ? "cached" : "computed",
               o.scene, r.value("reference", ""));
    fmt::print("stats: {}\n", r["stats"].dump());
    // Monte Carlo: the relative L2 norm of the per-region standard errors
    // (experiments/runner.h), the noise this reference adds to an L2 error.
    if (r.contains("mc_stderr_l2_lum"))
        fmt::print(
            "standard error: relative L2 {:.4g} (luminance), {:.4g} (RGB); {:.4g} (luminance, "
            "non-emitting patches only)\n",
            r["mc_stderr_l2_lum"].get<double>(), r["mc_stderr_l2_rgb"].get<double>(),
            r["mc_stderr_l2_nonemitter_lum"].get<double>());
    if (r.contains("reflected_power")) {
        const auto& pw = r["reflected_power"];
        fmt::print("reflected power: ({:.6g}, {:.6g}, {:.6g})", pw[0].get<double>(),
                   pw[1].get<double>(), pw[2].get<double>());
        if (r.contains("reflected_power_stderr")) {
            const auto& se = r["reflected_power_stderr"];
            fmt::print(" +- ({:.3g}, {:.3g}, {:.3g}) (one standard error)", se[0].get<double>(),
                       se[1].get<double>(), se[2].get<double>());
        }
        fmt::print(" [sum of A (B - E), RGB]\n");
    }
    if (r.contains("cache_file") && r["cache_file"].is_string())
        fmt::print("cache file: {} ({:.2f} s)\n", r["cache_file"].get<std::string>(),
                   r.value("seconds", 0.0));
    else
        fmt::print("cache file: none, the cache {} could not be written (see the warning above) "
                   "({:.2f} s)\n", r.value("cache_dir", ""), r.value("seconds", 0.0));
    return 0;
}

}  // namespace hrad::app
