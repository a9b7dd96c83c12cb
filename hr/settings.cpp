#include "hr/settings.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/memory.h"
#include "hr/checks/registry.h"
#include "hr/light_links.h"
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
    const std::string text = p.getString({"hr.checks",
                                             "the refinement checks that amend the oracle's "
                                             "decisions (hr/checks/): all, none, or names from "
                                             "the table; drop one to measure what it does"},
                                            "all");
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

/// A key set, to something else than a word such as "auto" (a number, a boolean).
bool isSetNotWord(const Params& p, const std::string& key) {
    auto it = p.entries().find(key);
    return it != p.entries().end() && !std::holds_alternative<std::string>(it->second.value);
}
}  // namespace

namespace {
/// The oracle, the eps schedule, the mesh and the loop.
void readMesh(const Params& p, HrSettings& s) {
    s.oracle =
        p.getEnum({"hr.oracle",
                   "refinement oracle (bfa: power a link carries, ff: form factor, uniform: fixed "
                   "depth, error/kv: error control); change to compare refinement criteria"},
                  s.oracle, oracles::oracleNames());
    s.oracleParams = p.subset("oracle");
    s.epsSchedule =
        parseSchedule(p.getString({"hr.eps_schedule",
                                   "decreasing eps values, comma-separated (multigridding: solve "
                                   "at each in turn); empty: the oracle's eps alone"},
                                  ""),
                      p.where("hr.eps_schedule"));
    s.minArea = p.getDouble(
        {"hr.min_area",
         "smallest element area (absolute, scene units^2); raise to cap the mesh on tiny features"},
        s.minArea, 0.0, 1e300);
    s.minAreaRel = p.getDouble({"hr.min_area_rel",
                                "smallest element area as a fraction of the scene's total area; "
                                "lower for finer meshes on large scenes"},
                               s.minAreaRel, 0.0, 1.0);
    s.maxLevel =
        int(p.getInt({"hr.max_level", "deepest quadtree level of an element below its root patch"},
                     s.maxLevel, 0, scene::kMaxLevel));
    s.maxIterations =
        int(p.getInt({"hr.max_iterations", "iteration cap of the refine-gather-push-pull loop"},
                     s.maxIterations, 1, 1000000));
    s.minIterations =
        int(p.getInt({"hr.min_iterations", "iterations run before convergence may stop the solve"},
                     s.minIterations, 1, 1000000));
    s.tolerance = p.getDouble({"hr.tolerance",
                               "convergence: relative change of reflected power (and error still "
                               "to come) below which the solve stops"},
                              s.tolerance, 0.0, 1.0, true);
}

/// The limits that stop refinement early (hr/budget.h).
void readLimits(const Params& p, HrSettings& s) {
    s.maxLinks = uint64_t(
        p.getInt({"hr.max_links",
                  "refinement stops past this many links (a memory guard); raise for huge scenes"},
                 int64_t(s.maxLinks), 1, int64_t(1) << 40));
    s.maxSeconds = p.getDouble(
        {"hr.max_seconds", "refinement stops after this wall time, seconds (0: no limit)"},
        s.maxSeconds, 0.0, 1e9);
    int64_t budgetMb = p.getInt(
        {"memory.budget_mb",
         "refinement stops before the process would pass this many MiB (0: 80 % of physical RAM)"},
        0, 0, int64_t(1) << 30);
    s.memoryBudget =
        budgetMb > 0 ? uint64_t(budgetMb) << 20 : uint64_t(0.8 * double(physicalMemoryBytes()));
    p.recordResolved("memory.budget_mb", int64_t(s.memoryBudget >> 20));
}

/// Form factors and clusters.
void readTransfer(const Params& p, HrSettings& s) {
    s.ff = transport::FormFactorSettings::fromParams(p, "ff");
    s.clusterModel = cluster::parseClusterModel(
        p.getEnum({"cluster.model",
                   "volume clustering: none (all patch pairs), isotropic (A/4), oriented (sum of A "
                   "cos); auto = none up to 2,000 patches, oriented above"},
                  "auto", cluster::clusterModelNames()));
    s.cluster = cluster::ClusterSettings::fromParams(p);
}

/// The refinement checks (hr/checks/) and the leaf estimates.
void readChecks(const Params& p, HrSettings& s) {
    // "auto" (the default), "off", or a fraction of the emitted power.
    const Params::Key receiverEps{"hr.receiver_eps",
                                  "receiver-aggregate error check added to bfa/ff: auto (from "
                                  "the oracle's eps), off, or a fraction of the emitted power in "
                                  "[0, 1]"};
    if (isSetNotWord(p, receiverEps.name))
        s.receiverEps = p.getDouble(receiverEps, 0.0, 0.0, 1.0);
    else
        s.receiverEps = p.getEnum(receiverEps, "auto", {"auto", "off"}) == "auto" ? -1.0 : 0.0;
    s.senderTotal = p.getBool({"hr.sender_total",
                               "error/kv also bound the sender-side error summed per sender over "
                               "all its receivers; off only to study the published oracles"},
                              s.senderTotal);
    parseChecks(p, s);
    s.importance = ImportanceSettings::fromParams(p);
    // true / "full", false / "off", or "balanced" (the default).
    const Params::Key leafBudget{"hr.leaf_budget",
                                 "push links down while the leaves' error exceeds the check's "
                                 "eps: balanced, full (true) or off (false)"};
    if (isSetNotWord(p, leafBudget.name)) {
        s.leafBudget = p.getBool(leafBudget, false) ? HrSettings::LeafBudget::Full
                                                    : HrSettings::LeafBudget::Off;
    } else {
        const std::string v = p.getEnum(leafBudget, "balanced", {"balanced", "full", "off"});
        s.leafBudget = v == "full"  ? HrSettings::LeafBudget::Full
                       : v == "off" ? HrSettings::LeafBudget::Off
                                    : HrSettings::LeafBudget::Balanced;
    }
    // The leaf budget sums unweighted errors: with importance on it is off
    // unless set (hr/checks/importance_check.cpp).
    if (s.importance.mode != ImportanceSettings::Mode::Off && !p.has(leafBudget.name)) {
        s.leafBudget = HrSettings::LeafBudget::Off;
        p.recordResolved(leafBudget.name, std::string("off"));
    }
    s.leafEstimates = p.getBool({"hr.leaf_estimates",
                                 "compute error_estimate_leaves and error_estimate_points after "
                                 "the solve; off saves their point form factors"},
                                s.leafEstimates);
}

/// The iteration: extrapolation, relaxation, lazy refinement, rays, noise, order.
void readIteration(const Params& p, HrSettings& s) {
    s.extrapolate = p.getBool({"hr.extrapolate",
                               "Aitken extrapolation of the gather iteration once refinement stops "
                               "(fast convergence of high-reflectance scenes)"},
                              s.extrapolate);
    s.relaxShare = p.getDouble({"hr.relax_share",
                                "relaxation: the share of an iteration's change the few "
                                "most-changing root patches must carry to be relaxed"},
                               s.relaxShare, 0.0, 1.0);
    s.relaxFraction = p.getDouble(
        {"hr.relax_fraction", "relaxation: at most this fraction of the root patches is relaxed"},
        s.relaxFraction, 0.0, 1.0);
    s.relaxSweeps = int(p.getInt(
        {"hr.relax_sweeps", "relaxation: gather sweeps over the relaxed root patches at most"},
        s.relaxSweeps, 1, 1 << 20));
    s.refineGrowth = p.getDouble({"hr.refine_growth",
                                  "lazy refinement: re-judge links only when the power they carry "
                                  "grew by this fraction (0: judge every iteration)"},
                                 s.refineGrowth, 0.0, 1e300);
    s.judgeVisibility = p.getEnum({"hr.judge_visibility",
                                   "visibility a surface link is judged by: independent (second "
                                   "set of ff.vis_rays rays) or carried (the link's own)"},
                                  s.judgeVisibility ? "independent" : "carried",
                                  {"independent", "carried"}) == "independent";
    s.epsPower =
        epsPowerFromName(p.getEnum({"hr.eps_power",
                                    "what eps is a fraction of: emitted power, reflected power so "
                                    "far, or the smaller of emitted and predicted reflected power"},
                                   epsPowerName(s.epsPower), epsPowerNames()));
    s.reachRays = int(p.getInt(
        {"hr.reach_rays",
         "rays per patch of the reachability pass that finds patches no light can reach (0: off)"},
        s.reachRays, 0, 1 << 20));
    s.reachRetryRays =
        int(p.getInt({"hr.reach_retry_rays",
                      "more reachability rays for each patch the first ones left unconnected"},
                     s.reachRetryRays, 0, 1 << 20));
    s.seed = uint64_t(p.getInt({"hr.seed",
                                "seed of every ray the solve casts: 0 repeats the same solve bit "
                                "for bit, other values draw independent rays"},
                               int64_t(s.seed), 0, int64_t(1) << 62));
    s.noiseTarget =
        p.getDouble({"hr.noise_target",
                     "relative ray noise the solve must reach, re-solving with more rays (0: off)"},
                    s.noiseTarget, 0.0, 1.0);
    s.noiseRounds = int(p.getInt({"hr.noise_rounds", "re-solves at most for hr.noise_target"},
                                 s.noiseRounds, 0, 16));
    s.noiseMaxFactor =
        p.getDouble({"hr.noise_max_factor",
                     "growth of ray counts at most, over all re-solves of hr.noise_target"},
                    s.noiseMaxFactor, 1.0, 1e6);
    s.gaussSeidel = p.getEnum({"hr.iteration",
                               "gather order: jacobi (all from the last iteration) or gauss-seidel "
                               "(root patches use radiosities just computed)"},
                              s.gaussSeidel ? "gauss-seidel" : "jacobi",
                              {"jacobi", "gauss-seidel"}) == "gauss-seidel";
    s.gsBlocks = int(p.getInt(
        {"hr.gs_blocks",
         "gauss-seidel: blocks of root patches gathered in turn (0: one block per root patch)"},
        s.gsBlocks, 0, 1 << 30));
}

/// Cluster links, partial receivers and the polynomial basis.
void readBasis(const Params& p, HrSettings& s) {
    s.clusterLink = cluster::ClusterLinkSettings::fromParams(p);
    s.openPartialReceivers =
        p.getEnum({"cluster.partial_receivers",
                   "open a partly visible link into a cluster when the light it may hand to unseen "
                   "surfaces exceeds eps (keep: as the oracle decides)"},
                  s.openPartialReceivers ? "open" : "keep", {"open", "keep"}) == "open";
    s.elementRho = p.getEnum({"hr.texture_rho",
                              "reflectance of the elements of a textured root patch: the patch's "
                              "texture mean (patch) or each element's own (element, hr/element_rho.h)"},
                             s.elementRho ? "element" : "patch", {"patch", "element"}) == "element";
    s.basisDegree = scene::basisDegree(
        p.getEnum({"hr.basis",
                   "polynomial basis on every element (constant, linear, quadratic, cubic: "
                   "Galerkin); higher degrees need fewer elements"},
                  "constant", scene::basisNames()));
    s.basisPoints = int(p.getInt(
        {"hr.basis_points", "coupling quadrature points per axis on each element (0: degree + 2)"},
        0, 0, 16));
    s.basisNearLevels =
        int(p.getInt({"hr.basis_near_levels",
                      "levels of the composite coupling rule used for near element pairs"},
                     s.basisDegree >= 3 ? 2 : s.basisNearLevels, 0, 4));
    s.basisCheck = p.getDouble({"hr.basis_check",
                                "relative error of point-to-point form factors past which a link "
                                "keeps only the sender's mean"},
                               s.basisCheck, 0.0, 1e300);
    if (s.gaussSeidel && s.basisDegree > 0)
        throwInputError(
            p.where("hr.iteration"),
            "hr.iteration = gauss-seidel needs hr.basis = constant (the polynomial push-pull "
            "runs over all root patches at once)");
}

}  // namespace

HrSettings HrSettings::fromParams(const Params& p) {
    Params::Scope scope(p, "hr solver");
    HrSettings s;
    readMesh(p, s);
    readLimits(p, s);
    readTransfer(p, s);
    readChecks(p, s);
    readIteration(p, s);
    readBasis(p, s);
    const LightLinkSettings lls = LightLinkSettings::fromParams(p);
    s.lightStrata = lls.strata;
    s.lightClusters = lls.clusters;
    // Validate the oracle settings now (unknown keys included), so a bad
    // setting fails before any work is done.
    // The probe is a subset of p, so the oracle's reads are p's records.
    Params probe = p.subset("oracle");
    oracles::createOracle(s.oracle, probe);
    probe.reportUnused();
    p.markUsedPrefix("oracle");
    return s;
}

}  // namespace hrad::hr
