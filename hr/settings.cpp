#include "hr/settings.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/memory.h"
#include "hr/checks/registry.h"
#include "oracles/registry.h"
#include "scene/basis.h"

namespace hrad::hr {

namespace {
std::vector<double> parseSchedule(const std::string& text, const SourceLocation& where) {
    std::vector<double> out;
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ',')) {
        if (item.find_first_not_of(" \t") == std::string::npos) continue;
        char* end = nullptr;
        double v = std::strtod(item.c_str(), &end);
        while (end && (*end == ' ' || *end == '\t')) ++end;
        if (!end || *end != '\0' || !(v > 0) || !std::isfinite(v))
            throwInputError(where, "hr.eps_schedule: '{}' is not a positive number", item);
        if (!out.empty() && v > out.back())
            throwInputError(where, "hr.eps_schedule must be decreasing ({} after {})", v,
                            out.back());
        out.push_back(v);
    }
    return out;
}
/// hr.checks: "all" (the default), "none", or names from the check table.
void parseChecks(const Params& p, HrSettings& s) {
    const std::string text = p.getString("hr.checks", "all");
    if (text == "all") return;
    s.allChecks = false;
    if (text == "none") return;
    std::vector<std::string> valid;
    for (const CheckEntry& e : refinementChecks()) valid.push_back(e.name);
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ',')) {
        item.erase(0, item.find_first_not_of(" \t"));
        item.erase(item.find_last_not_of(" \t") + 1);
        if (std::find(valid.begin(), valid.end(), item) == valid.end())
            throwInputError(p.where("hr.checks"), "hr.checks: unknown check '{}' (valid: all, none, {})",
                            item, fmt::join(valid, ", "));
        s.checks.push_back(item);
    }
}
}  // namespace

HrSettings HrSettings::fromParams(const Params& p) {
    HrSettings s;
    s.oracle = p.getEnum("hr.oracle", s.oracle, oracles::oracleNames());
    s.oracleParams = p.subset("oracle");
    s.epsSchedule = parseSchedule(p.getString("hr.eps_schedule", ""), p.where("hr.eps_schedule"));
    s.minArea = p.getDouble("hr.min_area", s.minArea, 0.0, 1e300);
    s.minAreaRel = p.getDouble("hr.min_area_rel", s.minAreaRel, 0.0, 1.0);
    s.maxLevel = int(p.getInt("hr.max_level", s.maxLevel, 0, scene::kMaxLevel));
    s.maxIterations = int(p.getInt("hr.max_iterations", s.maxIterations, 1, 1000000));
    s.minIterations = int(p.getInt("hr.min_iterations", s.minIterations, 1, 1000000));
    s.tolerance = p.getDouble("hr.tolerance", s.tolerance, 0.0, 1.0, true);
    s.maxLinks = uint64_t(p.getInt("hr.max_links", int64_t(s.maxLinks), 1, int64_t(1) << 40));
    s.maxSeconds = p.getDouble("hr.max_seconds", s.maxSeconds, 0.0, 1e9);
    int64_t budgetMb = p.getInt("memory.budget_mb", 0, 0, int64_t(1) << 30);
    s.memoryBudget =
        budgetMb > 0 ? uint64_t(budgetMb) << 20 : uint64_t(0.8 * double(physicalMemoryBytes()));
    s.ff = transport::FormFactorSettings::fromParams(p, "ff");
    s.clusterModel = cluster::parseClusterModel(
        p.getEnum("cluster.model", "auto", cluster::clusterModelNames()));
    s.cluster = cluster::ClusterSettings::fromParams(p);
    // "auto" (the default), "off", or a fraction of the emitted power.
    if (auto it = p.entries().find("hr.receiver_eps");
        it != p.entries().end() && std::holds_alternative<std::string>(it->second.value))
        s.receiverEps =
            p.getEnum("hr.receiver_eps", "auto", {"auto", "off"}) == "auto" ? -1.0 : 0.0;
    else if (p.has("hr.receiver_eps"))
        s.receiverEps = p.getDouble("hr.receiver_eps", 0.0, 0.0, 1.0);
    s.senderTotal = p.getBool("hr.sender_total", s.senderTotal);
    parseChecks(p, s);
    // true / "full", false / "off", or "balanced" (the default).
    if (auto it = p.entries().find("hr.leaf_budget");
        it != p.entries().end() && std::holds_alternative<std::string>(it->second.value)) {
        const std::string v = p.getEnum("hr.leaf_budget", "balanced", {"balanced", "full", "off"});
        s.leafBudget = v == "full"  ? HrSettings::LeafBudget::Full
                       : v == "off" ? HrSettings::LeafBudget::Off
                                    : HrSettings::LeafBudget::Balanced;
    } else if (p.has("hr.leaf_budget")) {
        s.leafBudget = p.getBool("hr.leaf_budget", false) ? HrSettings::LeafBudget::Full
                                                           : HrSettings::LeafBudget::Off;
    }
    s.leafEstimates = p.getBool("hr.leaf_estimates", s.leafEstimates);
    s.extrapolate = p.getBool("hr.extrapolate", s.extrapolate);
    s.relaxShare = p.getDouble("hr.relax_share", s.relaxShare, 0.0, 1.0);
    s.relaxFraction = p.getDouble("hr.relax_fraction", s.relaxFraction, 0.0, 1.0);
    s.relaxSweeps = int(p.getInt("hr.relax_sweeps", s.relaxSweeps, 1, 1 << 20));
    s.refineGrowth = p.getDouble("hr.refine_growth", s.refineGrowth, 0.0, 1e300);
    s.judgeVisibility =
        p.getEnum("hr.judge_visibility", s.judgeVisibility ? "independent" : "carried",
                  {"independent", "carried"}) == "independent";
    s.epsPower =
        epsPowerFromName(p.getEnum("hr.eps_power", epsPowerName(s.epsPower), epsPowerNames()));
    s.reachRays = int(p.getInt("hr.reach_rays", s.reachRays, 0, 1 << 20));
    s.reachRetryRays = int(p.getInt("hr.reach_retry_rays", s.reachRetryRays, 0, 1 << 20));
    s.seed = uint64_t(p.getInt("hr.seed", int64_t(s.seed), 0, int64_t(1) << 62));
    s.noiseTarget = p.getDouble("hr.noise_target", s.noiseTarget, 0.0, 1.0);
    s.noiseRounds = int(p.getInt("hr.noise_rounds", s.noiseRounds, 0, 16));
    s.noiseMaxFactor = p.getDouble("hr.noise_max_factor", s.noiseMaxFactor, 1.0, 1e6);
    s.gaussSeidel = p.getEnum("hr.iteration", s.gaussSeidel ? "gauss-seidel" : "jacobi",
                              {"jacobi", "gauss-seidel"}) == "gauss-seidel";
    s.gsBlocks = int(p.getInt("hr.gs_blocks", s.gsBlocks, 0, 1 << 30));
    s.clusterLink = cluster::ClusterLinkSettings::fromParams(p);
    s.openPartialReceivers =
        p.getEnum("cluster.partial_receivers", s.openPartialReceivers ? "open" : "keep",
                  {"open", "keep"}) == "open";
    s.basisDegree = scene::basisDegree(p.getEnum("hr.basis", "constant", scene::basisNames()));
    s.basisPoints = int(p.getInt("hr.basis_points", 0, 0, 16));
    s.basisNearLevels =
        int(p.getInt("hr.basis_near_levels", s.basisDegree >= 3 ? 2 : s.basisNearLevels, 0, 4));
    s.basisCheck = p.getDouble("hr.basis_check", s.basisCheck, 0.0, 1e300);
    if (s.gaussSeidel && s.basisDegree > 0)
        throwInputError(
            p.where("hr.iteration"),
            "hr.iteration = gauss-seidel needs hr.basis = constant (the polynomial push-pull "
            "runs over all root patches at once)");
    // Validate the oracle settings now (unknown keys included), so a bad
    // setting fails before any work is done.
    Params probe = s.oracleParams;
    oracles::createOracle(s.oracle, probe);
    probe.reportUnused();
    p.markUsedPrefix("oracle");
    return s;
}

std::string HrSettings::describe() const {
    std::string sched = fmt::format("{}", fmt::join(epsSchedule, ","));
    return fmt::format(
               "hr(oracle={}, eps_schedule=[{}], min_area={}, min_area_rel={}, max_level={}, "
               "max_iterations={}, tolerance={}, iteration={}, {}, cluster_model={}, {}, {})",
               oracle, sched, minArea, minAreaRel, maxLevel, maxIterations, tolerance,
               gaussSeidel ? fmt::format("gauss-seidel/{}", gsBlocks) : std::string("jacobi"),
               ff.describe(), cluster::clusterModelName(clusterModel), cluster.describe(),
               clusterLink.describe()) +
           (basisDegree > 0
                ? fmt::format(" basis={} basis_points={} basis_near_levels={} basis_check={}",
                              scene::basisName(basisDegree),
                              basisPoints > 0 ? basisPoints : basisDegree + 2, basisNearLevels,
                              basisCheck)
                : std::string()) +
           (noiseTarget > 0 ? fmt::format(" noise_target={} noise_rounds={} noise_max_factor={}",
                                          noiseTarget, noiseRounds, noiseMaxFactor)
                            : std::string());
}

}  // namespace hrad::hr
