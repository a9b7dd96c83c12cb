// `hrad settings [PREFIX] [--markdown]`: every key some component reads, with
// its default, type, range, reader and doc (experiments/settings_reference.h),
// and the help texts main.cpp shows, generated from the registries.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cstdio>

#include "apps/commands.h"
#include "cluster/transfer.h"
#include "cluster/tree.h"
#include "core/error.h"
#include "experiments/settings_reference.h"
#include "experiments/solvers.h"
#include "oracles/registry.h"
#include "scene/builtin.h"
#include "scene/loader.h"

namespace hrad::app {

void readAppSettings(const Params& params) {
    Params::Scope scope(params, "hrad solve");
    readReferenceLevel(params);
}

int readReferenceLevel(const Params& params) {
    return int(params.getInt({"metrics.reference_level",
                              "hrad solve: also a full-matrix reference at this uniform level, "
                              "and the error against it (-1: none)"},
                             -1, -1, 12));
}

int runSettings(const SettingsCliOptions& opt) {
    const std::vector<Params::Record> all = experiments::settingsReference(&readAppSettings);
    std::string out;
    if (opt.readme)
        out = experiments::settingsReadmeTable(all);
    else if (opt.markdown)
        out = experiments::settingsMarkdown(all, opt.prefix);
    else
        out = experiments::settingsText(all, opt.prefix);
    if (out.empty() || (opt.markdown && out.find("\n| `") == std::string::npos))
        throwInputError({"command line", 0, 0},
                        "no setting starts with '{}' (hrad settings lists them all)", opt.prefix);
    std::fputs(out.c_str(), stdout);
    return 0;
}

std::string registryHelp(const std::string& family) {
    auto names = [](const std::vector<std::string>& v) {
        return fmt::format("{}", fmt::join(v, ", "));
    };
    if (family == "solver") return names(experiments::solverNames());
    if (family == "oracle") return names(oracles::oracleNames());
    if (family == "cluster") return names(cluster::clusterModelNames());
    if (family == "builder") return names(cluster::builderNames());
    if (family == "format") {
        std::vector<std::string> ext;
        for (const scene::SceneFormat& f : scene::sceneFormats())
            for (const std::string& e : f.extensions) ext.push_back(e);
        return names(ext);
    }
    if (family == "builtin") return names(scene::builtinNames());
    return "?";
}

}  // namespace hrad::app
