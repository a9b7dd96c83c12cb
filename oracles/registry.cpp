#include "oracles/registry.h"

#include <functional>
#include <utility>

#include "oracles/bfa_oracle.h"
#include "oracles/error_oracle.h"
#include "oracles/ff_oracle.h"
#include "oracles/kv_oracle.h"
#include "oracles/uniform_oracle.h"

namespace hrad::oracles {

namespace {
using Factory = std::function<std::unique_ptr<Oracle>(const Params&)>;

const std::vector<std::pair<std::string, Factory>>& table() {
    static const std::vector<std::pair<std::string, Factory>> t = {
        {"bfa",
         [](const Params& p) {
             return std::make_unique<PowerOracle>(PowerOracle::Settings::fromParams(p));
         }},
        {"ff",
         [](const Params& p) {
             return std::make_unique<FormFactorOracle>(FormFactorOracle::Settings::fromParams(p));
         }},
        {"error",
         [](const Params& p) {
             return std::make_unique<ErrorBoundOracle>(VariationOracle::Settings::fromParams(p));
         }},
        {"kv",
         [](const Params& p) {
             return std::make_unique<KernelVariationOracle>(
                 VariationOracle::Settings::fromParams(p));
         }},
        {"uniform",
         [](const Params& p) {
             return std::make_unique<UniformOracle>(UniformOracle::Settings::fromParams(p));
         }},
    };
    return t;
}
}  // namespace

std::vector<std::string> oracleNames() {
    std::vector<std::string> names;
    for (const auto& [n, f] : table()) names.push_back(n);
    return names;
}

std::unique_ptr<Oracle> createOracle(const std::string& name, const Params& params,
                                     const SourceLocation& where) {
    for (const auto& [n, f] : table())
        if (n == name) {
            Params::Scope scope(params, "oracle " + n);
            return f(params);
        }
    throwInputError(where, "unknown oracle '{}'; valid oracles: {}", name,
                    fmt::join(oracleNames(), ", "));
}

}  // namespace hrad::oracles
