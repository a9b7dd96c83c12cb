#include "experiments/solvers.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <utility>

#include "hr/solver.h"
#include "reference/fullmatrix.h"
#include "reference/progressive.h"

namespace hrad::experiments {

using nlohmann::json;

namespace {

json rgbJson(const RGB& c) { return json::array({c.r, c.g, c.b}); }
json nanToNull(double v) { return std::isnan(v) ? json(nullptr) : json(v); }

/// One hr history record as summary.history holds it.
json hrRecordJson(const hr::IterationRecord& it) {
    return json{{"iteration", it.iteration},
                {"stage", it.stage},
                {"eps", nanToNull(it.eps)},
                {"links", it.links},
                {"elements", it.elements},
                {"leaves", it.leaves},
                {"refined_links", it.refinedLinks},
                {"judged", it.judged},
                {"rays", it.rays},
                {"form_factors", it.formFactors},
                {"residual", it.residual},
                {"iteration_error",
                 std::isfinite(it.iterationError) ? json(it.iterationError) : json(nullptr)},
                {"extrapolation", it.extrapolation},
                {"relaxed_patches", it.relaxedPatches},
                {"relax_sweeps", it.relaxSweeps},
                {"reflected_power", rgbJson(it.reflectedPower)},
                {"refine_s", it.refineSeconds},
                {"gather_s", it.gatherSeconds},
                {"push_pull_s", it.pushPullSeconds},
                {"element_bytes", it.elementBytes},
                {"link_bytes", it.linkBytes},
                {"peak_rss", it.peakRss},
                {"l2_lum", nanToNull(it.l2Lum)}};
}

// ---- hr: hierarchical radiosity (hr/solver.h) ------------------------------------
/// SolveContext::afterStage as the solver's stage controller.
class StageCallback final : public hr::StageController {
  public:
    explicit StageCallback(const SolveContext& ctx) : ctx_(ctx) {}
    std::optional<double> afterStage(const hr::Hierarchy& h, double eps) override {
        hr::HierarchyField f(h);
        return ctx_.afterStage(f, eps);
    }

  private:
    const SolveContext& ctx_;
};

class HrEntry final : public Solver {
  public:
    explicit HrEntry(const Params& p) : settings_(hr::HrSettings::fromParams(p)) {}

    SolveOutput solve(const scene::Scene& sc, const transport::Visibility& vis,
                      const SolveContext& ctx) const override {
        hr::HrSettings settings = settings_;
        if (settings.importance.mode == hr::ImportanceSettings::Mode::Camera && ctx.camera) {
            settings.importance.camera = ctx.camera();
            settings.importance.width = ctx.imageWidth;
            settings.importance.height = ctx.imageHeight;
        }
        hr::HrSolver s(sc, vis, settings);
        s.setCancelToken(ctx.cancel);
        StageCallback stages(ctx);
        if (ctx.afterStage) s.setStageController(&stages);
        if (ctx.historyError || ctx.onRecord)
            s.setIterationHook([&](const hr::Hierarchy& hh, hr::IterationRecord& rec) {
                if (ctx.historyError) {
                    hr::HierarchyField f(hh);
                    rec.l2Lum = ctx.historyError(f);
                }
                if (ctx.onRecord) ctx.onRecord(hrRecordJson(rec));
            });
        auto res = std::make_shared<hr::HrResult>(s.solve(ctx.progress));
        // hr.texture_rho = element on a scene with textured patches: the
        // leaves carry their own reflectance (scene/field.h leafTextureRho),
        // which the picture divides by (render/texturing.h).
        res->field->setLeafTextureRho(res->hierarchy->elementRhoBytes() > 0);
        SolveOutput out;
        out.field = res->field.get();
        const hr::Hierarchy& h = *res->hierarchy;
        json& sm = out.summary;
        sm["oracle"] = res->oracleDescription;
        sm["cluster_model"] = res->clusterModel;
        sm["converged"] = res->converged;
        sm["residual"] = res->history.empty() ? json(nullptr) : json(res->history.back().residual);
        sm["iteration_error"] =
            res->history.empty() || !std::isfinite(res->history.back().iterationError)
                ? json(nullptr)
                : json(res->history.back().iterationError);
        sm["link_cap_hit"] = res->linkCapHit;
        sm["memory_budget_hit"] = res->memoryBudgetHit;
        sm["time_limit_hit"] = res->timeLimitHit;
        sm["interrupted"] = res->interrupted;
        sm["eps_power"] =
            json{{"of", hr::epsPowerName(res->epsPowerOf)}, {"value", res->epsPower}};
        sm["min_area"] = res->minArea;
        sm["error_estimate"] = res->errorEstimate;
        auto orNull = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
        sm["error_estimate_leaves"] = orNull(res->errorEstimateLeaves);
        sm["error_estimate_points"] = orNull(res->errorEstimatePoints);
        sm["error_estimate_uncovered_share"] = orNull(res->errorEstimateUncovered);
        sm["stand_in_power_share"] = res->standInPowerShare;
        {
            // The refinement checks (hr/checks/), in amendment order: the
            // judging passes each took part in and the decisions it changed.
            json checks = json::array();
            for (const hr::CheckUse& c : res->checks)
                checks.push_back({{"name", c.name}, {"passes", c.passes}, {"amended", c.amended}});
            sm["refinement_checks"] = checks;
        }
        {
            const hr::SolverNoise& n = res->noise;
            auto rgb = [](const RGB& v) { return json::array({v.r, v.g, v.b}); };
            sm["noise_estimate"] = n.relative;
            if (settings_.noiseTarget > 0)
                sm["noise_control"] = json{{"target", settings_.noiseTarget},
                                           {"met", n.relative <= settings_.noiseTarget},
                                           {"rounds", res->noiseRounds},
                                           {"ray_factor", res->noiseRayFactor},
                                           {"first_noise", res->noiseFirst},
                                           {"seconds", res->noiseRoundsSeconds}};
            sm["noise"] = json{{"reflected_power_sd", rgb(n.powerSd)},
                               {"direct_sd", rgb(n.direct)},
                               {"amplification", rgb(n.amplification)},
                               {"relative", n.relative},
                               {"l2_nonemitter_direct", n.l2NonEmitter},
                               {"noisy_links", n.links}};
        }
        sm["counts"] = json{{"elements", h.numElements()},
                            {"leaves", h.numLeaves()},
                            {"links", h.numLinks()},
                            {"initial_links", res->initialLinks},
                            {"initial_pairs", res->initialPairs},
                            {"unreachable_patches", res->unreachablePatches},
                            {"reach_rays", res->reachRays},
                            {"handover_rays", res->opennessRays},
                            {"handover_by_openness", res->handOverByOpenness},
                            {"handover_by_cosine", res->handOverByCosine},
                            {"handover_capped", res->handOverCapped},
                            {"links_ss", res->linksSS},
                            {"links_sc", res->linksSC},
                            {"links_cs", res->linksCS},
                            {"links_cc", res->linksCC},
                            {"rays", res->totalRays},
                            {"form_factors", res->totalFormFactors},
                            {"deferred_links_computed", res->deferredLinksComputed},
                            {"deferred_links_left", res->deferredLinksLeft},
                            {"unopened_links", res->unopenedLinks},
                            {"stand_in_links", res->standInLinks},
                            {"stand_in_rays", res->standInRays},
                            {"near_stand_ins_made", res->nearStandInsMade},
                            {"near_stand_in_rays", res->nearStandInRays},
                            {"stand_in_links_final", res->standInLinksFinal},
                            {"iterations", res->history.size()}};
        {
            // Where refinement spends, by link kind (HrResult::linkCost).
            static const char* kKinds[4] = {"ss", "sc", "cs", "cc"};
            json ev, rays, secs;
            for (int k = 0; k < 4; ++k) {
                ev[kKinds[k]] = res->linkCost.evaluations[k];
                rays[kKinds[k]] = res->linkCost.rays[k];
                secs[kKinds[k]] = res->linkCost.seconds[k];
            }
            sm["link_cost"] = json{{"evaluations", ev}, {"rays", rays}, {"cpu_seconds", secs}};
        }
        json& t = out.timings;
        if (res->clusterTree) t["cluster_build"] = res->clusterBuildSeconds;
        t["reachability"] = res->reachSeconds;
        if (res->openness) t["handover_openness"] = res->opennessSeconds;
        t["linking"] = res->linkingSeconds;
        t["refine"] = res->refineSeconds;
        t["gather"] = res->gatherSeconds;
        t["push_pull"] = res->pushPullSeconds;
        t["error_estimate"] = res->errorEstimateSeconds;
        t["noise_estimate"] = res->noiseSeconds;
        if (res->standInLinks > 0) t["stand_in"] = res->standInSeconds;
        if (res->nearStandInsMade > 0) t["near_stand_in"] = res->nearStandInSeconds;
        for (const auto& [k, v] : res->memory.all()) out.memory.set(k, v);
        json hist = json::array();
        for (const auto& it : res->history) hist.push_back(hrRecordJson(it));
        sm["history"] = hist;
        if (h.numLinks())
            sm["bytes_per_link"] =
                json{{"link_storage", double(h.linkBytes()) / double(h.numLinks())},
                     {"links_and_elements",
                      double(h.linkBytes() + h.elementBytes()) / double(h.numLinks())}};
        out.owner = std::move(res);
        return out;
    }

  private:
    hr::HrSettings settings_;
};

// ---- full-matrix: all n^2 form factors (reference/fullmatrix.h) -------------------
class FullMatrixEntry final : public Solver {
  public:
    explicit FullMatrixEntry(const Params& p)
        : settings_(reference::FullMatrixSettings::fromParams(p, "fm")) {}

    SolveOutput solve(const scene::Scene& sc, const transport::Visibility& vis,
                      const SolveContext& ctx) const override {
        auto res = std::make_shared<reference::FullMatrixResult>(
            reference::solveFullMatrix(sc, vis, settings_, ctx.progress, StopPoll{ctx.cancel}));
        SolveOutput out;
        out.field = res->field.get();
        const auto& st = res->stats;
        out.summary["counts"] = json{{"elements", st.elements},
                                     {"leaves", st.elements},
                                     {"form_factors", st.formFactors},
                                     {"rays", st.rays},
                                     {"iterations", st.iterations}};
        out.summary["residual"] = st.residual;
        out.summary["converged"] = st.converged;
        out.summary["interrupted"] = st.interrupted;
        out.timings["form_factors"] = st.ffSeconds;
        out.timings["solve"] = st.solveSeconds;
        out.memory.set("matrix", st.matrixBytes);
        out.owner = std::move(res);
        return out;
    }

  private:
    reference::FullMatrixSettings settings_;
};

/// One progressive history record as summary.history holds it.
json progressiveRecordJson(const reference::ProgressiveRecord& it) {
    return json{{"iteration", it.shots},
                {"shooter", it.shooter},
                {"residual", it.unshotFraction},
                {"elements", it.elements},
                {"leaves", it.elements},
                {"form_factors", it.formFactors},
                {"rays", it.rays},
                {"seconds", it.seconds},
                {"element_bytes", it.bytes},
                {"l2_lum", nanToNull(it.l2Lum)}};
}

// ---- progressive: progressive refinement (reference/progressive.h) ----------------
class ProgressiveEntry final : public Solver {
  public:
    explicit ProgressiveEntry(const Params& p)
        : settings_(reference::ProgressiveSettings::fromParams(p, "pr")) {}

    SolveOutput solve(const scene::Scene& sc, const transport::Visibility& vis,
                      const SolveContext& ctx) const override {
        reference::ProgressiveHook hook;
        if (ctx.historyError || ctx.onRecord)
            hook = [&](const scene::RadiosityField& f, reference::ProgressiveRecord& rec) {
                if (ctx.historyError) rec.l2Lum = ctx.historyError(f);
                if (ctx.onRecord) ctx.onRecord(progressiveRecordJson(rec));
            };
        auto res = std::make_shared<reference::ProgressiveResult>(
            reference::solveProgressive(sc, vis, settings_, ctx.progress, hook, StopPoll{ctx.cancel}));
        SolveOutput out;
        out.field = res->field.get();
        out.summary["counts"] =
            json{{"elements", res->elements}, {"leaves", res->elements},
                 {"patches", res->patches},   {"form_factors", res->formFactors},
                 {"rays", res->rays},         {"iterations", res->shots}};
        out.summary["residual"] = res->unshotFraction;
        out.summary["converged"] = res->converged;
        out.summary["interrupted"] = res->interrupted;
        out.timings["solve"] = res->seconds;
        out.memory.set("progressive", res->bytes);
        json hist = json::array();
        for (const auto& it : res->history) hist.push_back(progressiveRecordJson(it));
        out.summary["history"] = hist;
        out.owner = std::move(res);
        return out;
    }

  private:
    reference::ProgressiveSettings settings_;
};

using Factory = std::function<std::unique_ptr<Solver>(const Params&)>;

struct Entry {
    SolverInfo info;
    Factory factory;
};

template <class T>
Factory make() {
    return [](const Params& p) { return std::make_unique<T>(p); };
}

const std::vector<Entry>& table() {
    static const std::vector<Entry> t = {
        {{"hr",
          "hierarchical radiosity, optional clustering (Hanrahan et al. 1991; Smits et al. 1994)",
          {"hr.", "oracle.", "cluster.", "ff.", "memory."},
          true,
          "one record per gather iteration"},
         make<HrEntry>()},
        {{"full-matrix",
          "uniform mesh, n^2 form factors, Jacobi / Gauss-Seidel / Southwell (Cohen & Wallace "
          "1993)",
          {"fm."},
          false,
          ""},
         make<FullMatrixEntry>()},
        {{"progressive",
          "progressive refinement with substructuring (Cohen, Chen, Wallace & Greenberg 1988)",
          {"pr."},
          true,
          "one record every pr.history_every shots"},
         make<ProgressiveEntry>()},
    };
    return t;
}

}  // namespace

bool SolverInfo::readsKey(const std::string& key) const {
    for (const auto& p : keyPrefixes)
        if (key.rfind(p, 0) == 0) return true;
    return false;
}

std::vector<std::string> solverNames() {
    std::vector<std::string> names;
    for (const auto& e : table()) names.push_back(e.info.name);
    return names;
}

const SolverInfo* findSolver(const std::string& name) {
    for (const auto& e : table())
        if (e.info.name == name) return &e.info;
    return nullptr;
}

const SolverInfo& solverInfo(const std::string& name, const SourceLocation& where) {
    if (const SolverInfo* i = findSolver(name)) return *i;
    throwInputError(where, "unknown solver '{}'; valid solvers: {}", name,
                    fmt::join(solverNames(), ", "));
}

std::unique_ptr<Solver> createSolver(const std::string& name, const Params& params,
                                     const SourceLocation& where) {
    for (const auto& e : table())
        if (e.info.name == name) return e.factory(params);
    throwInputError(where, "unknown solver '{}'; valid solvers: {}", name,
                    fmt::join(solverNames(), ", "));
}

}  // namespace hrad::experiments
