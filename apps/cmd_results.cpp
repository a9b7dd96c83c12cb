// `hrad results export|merge`: results-store maintenance (experiments/store.h).
#include <filesystem>

#include <fmt/format.h>

#include "apps/commands.h"
#include "experiments/store.h"

namespace hrad::app {

int runResultsExport(const std::string& store, const std::string& csvDir) {
    experiments::ResultStore s(store, true);
    s.exportCsv(csvDir);
    fmt::print("exported {} run(s), {} iteration row(s), {} failure(s) to {}/{{studies,runs,"
               "iterations,failures}}.csv\n",
               s.count("runs"), s.count("iterations"), s.count("failures"), csvDir);
    return 0;
}

int runResultsMerge(const std::string& out, const std::vector<std::string>& inputs, bool force) {
    // Every input passes the store checks before the output is created.
    for (const auto& in : inputs) experiments::ResultStore check(in, true);
    experiments::ResultStore s(out);
    for (const auto& in : inputs) {
        if (std::filesystem::equivalent(in, out))
            throwInputError({in, 0, 0}, "cannot merge a store into itself");
        int64_t added = s.mergeFrom(in, force);
        fmt::print("{}: {} new run(s)\n", in, added);
    }
    fmt::print("{}: {} run(s), {} failure(s)\n", out, s.count("runs"), s.count("failures"));
    return 0;
}

}  // namespace hrad::app
