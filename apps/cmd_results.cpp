// `hrad results export|merge`: results-store maintenance (experiments/store.h).
#include <filesystem>

#include <fmt/format.h>

#include "apps/commands.h"
#include "experiments/store.h"

namespace hrad::app {

int runResultsExport(const std::string& store, const std::string& csvDir) {
    if (!std::filesystem::exists(store)) throw Error(fmt::format("no such results store: {}", store));
    experiments::ResultStore s(store, true);
    s.exportCsv(csvDir);
    fmt::print("exported {} run(s), {} iteration row(s), {} failure(s) to {}/{{studies,runs,"
               "iterations,failures}}.csv\n",
               s.count("runs"), s.count("iterations"), s.count("failures"), csvDir);
    return 0;
}

int runResultsMerge(const std::string& out, const std::vector<std::string>& inputs) {
    experiments::ResultStore s(out);
    for (const auto& in : inputs) {
        if (std::filesystem::exists(out) && std::filesystem::equivalent(in, out))
            throw Error(fmt::format("cannot merge {} into itself", in));
        int64_t added = s.mergeFrom(in);
        fmt::print("{}: {} new run(s)\n", in, added);
    }
    fmt::print("{}: {} run(s), {} failure(s)\n", out, s.count("runs"), s.count("failures"));
    return 0;
}

}  // namespace hrad::app
