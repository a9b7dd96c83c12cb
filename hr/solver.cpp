#include "hr/solver.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <optional>
#include <sstream>
#include <unordered_map>

#include "core/interrupt.h"
#include "core/log.h"
#include "core/memory.h"
#include "core/rng.h"
#include "core/timer.h"
#include "hr/eps_power.h"
#include "hr/handover.h"
#include "hr/iteration_tail.h"
#include "hr/receiver_error.h"
#include "hr/light_links.h"
#include "hr/refiner.h"
#include "transport/light_irradiance.h"
#include "hr/checks/registry.h"
#include "oracles/registry.h"
#include "transport/reachability.h"
#include "core/phase_progress.h"

namespace hrad::hr {

using oracles::Decision;

namespace {
// Lazy refinement (solver.h): true when some element's radiosity, in some
// channel, has grown by more than the fraction g since the judging pass that
// recorded `judged` (from zero: any growth).
bool grownSince(const std::vector<RGB>& now, const std::vector<RGB>& judged, double g) {
    if (now.size() != judged.size()) return true;
    for (size_t e = 0; e < now.size(); ++e)
        for (int c = 0; c < 3; ++c)
            if (now[e][c] > judged[e][c] + g * std::fabs(judged[e][c])) return true;
    return false;
}

double relativeChange(const RGB& now, const RGB& before) {
    double num = maxComponent(glm::abs(now - before));
    double den = maxComponent(glm::abs(now));
    if (den <= 0) return num > 0 ? 1.0 : 0.0;
    return num / den;
}
}  // namespace

HrSolver::HrSolver(const scene::Scene& scene, const transport::Visibility& visibility,
                   HrSettings settings, const std::vector<CheckEntry>& extraChecks)
    : scene_(&scene),
      vis_(&visibility),
      s_(std::move(settings)),
      engine_(scene, &visibility, s_.ff),
      links_(engine_, s_.judgeVisibility) {
    minArea_ = s_.minArea > 0 ? s_.minArea : s_.minAreaRel * scene.totalArea();
    emittedPower_ = maxComponent(scene.emittedPower()) + transport::lightsPower(scene);  // + lights
    if (!(emittedPower_ > 0)) emittedPower_ = 1.0;
    epsPower_ = emittedPower_;
    emittedRadiosity_ = 0.0;
    for (const auto& patch : scene.patches)
        emittedRadiosity_ = std::max(emittedRadiosity_, maxComponent(patch.emission));
    if (!(emittedRadiosity_ > 0)) emittedRadiosity_ = 1.0;
    extraChecks_ = extraChecks;
    checks_ = makeRefinementChecks(s_, extraChecks);
    if (s_.basisDegree > 0) {
        basis_ = std::make_unique<scene::BasisSet>(s_.basisDegree);
        coupling_ = std::make_unique<transport::CouplingEngine>(
            scene, &visibility, engine_, *basis_,
            s_.basisPoints > 0 ? s_.basisPoints : s_.basisDegree + 2, s_.basisNearLevels,
            s_.basisCheck);
    }
    const uint64_t couplingBytes =
        coupling_ ? sizeof(float) * uint64_t(basis_->size() * basis_->size()) : 0;
    budget_ = std::make_unique<RefinementBudget>(s_, solveTimer_, couplingBytes);
}

struct HrSolver::PreviousCoupling {
    std::unordered_map<uint64_t, uint32_t> index;  ///< (receiver << 32 | sender) -> entry
    std::vector<float> data;
};

HrSolver::PreviousCoupling HrSolver::snapshotCoupling(const Hierarchy& h) const {
    PreviousCoupling p;
    const auto& idx = h.couplingIndex();
    if (idx.empty()) return p;
    p.index.reserve(idx.size());
    for (uint32_t r = 0; r < h.numElements(); ++r)
        for (uint64_t i = h.linkBegin(r); i < h.linkEnd(r); ++i)
            if (idx[i] != kNone) p.index.emplace((uint64_t(r) << 32) | h.link(i).sender, idx[i]);
    p.data = h.couplingData();
    return p;
}

uint64_t HrSolver::updateCoupling(Hierarchy& h, const PreviousCoupling* previous) const {
    if (!coupling_) return 0;
    const int nb = h.basisSize();
    const size_t nn = size_t(nb * nb);
    std::vector<uint32_t> recv = h.linkReceivers();
    const uint64_t n = h.numLinks();
    // Surface-surface links carrying something get a matrix; entries in link order.
    std::vector<uint32_t> index(n, kNone);
    uint32_t count = 0;
    for (uint64_t i = 0; i < n; ++i) {
        const Link& l = h.link(i);
        if (l.K > 0 && !h.isCluster(recv[i]) && !h.isCluster(l.sender)) index[i] = count++;
    }
    std::vector<float> data(size_t(count) * nn, 0.f);
    std::atomic<uint64_t> rays{0};
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, n, 256), [&](const auto& range) {
        uint64_t local = 0;
        for (uint64_t i = range.begin(); i != range.end(); ++i) {
            if (index[i] == kNone) continue;
            uint32_t r = recv[i], s = h.link(i).sender;
            float* out = data.data() + size_t(index[i]) * nn;
            if (previous) {
                auto it = previous->index.find((uint64_t(r) << 32) | s);
                if (it != previous->index.end()) {
                    std::copy_n(previous->data.data() + size_t(it->second) * nn, nn, out);
                    continue;
                }
            }
            const Link& l = h.link(i);
            transport::ElementRef er{h.patch(r), h.domain(r), h.stableId(r)};
            transport::ElementRef es{h.patch(s), h.domain(s), h.stableId(s)};
            local += coupling_->compute(er, es, h.carriedVisibility(l),
                                        (l.flags & Link::kPartial) != 0, out);
        }
        rays += local;
    });
    h.setCoupling(std::move(index), std::move(data));
    return rays;
}

void HrSolver::standInNear(Hierarchy& h, const std::vector<uint32_t>& recv,
                           std::vector<Link>& links, HrResult& res, IterationRecord& rec) const {
    if (!linker_ || !linker_->settings().standInNear) return;
    Timer t;
    std::vector<size_t> open;
    for (size_t i = 0; i < links.size(); ++i)
        if ((links[i].flags & Link::kOpen) &&
            linker_->standInNear(links_.endOf(h, recv[i]), links_.endOf(h, links[i].sender)))
            open.push_back(i);
    if (open.empty()) return;
    const uint64_t rays = links_.standIns(h, recv, links, open, true);
    countStandIns(res, rec, open.size(), rays, t.seconds(), true);
}

void HrSolver::countStandIns(HrResult& res, IterationRecord& rec, uint64_t links, uint64_t rays,
                             double seconds, bool near) const {
    (near ? res.nearStandInsMade : res.standInLinks) += links;
    (near ? res.nearStandInRays : res.standInRays) += rays;
    (near ? res.nearStandInSeconds : res.standInSeconds) += seconds;
    rec.rays += rays;  // the iteration's rays join res.totalRays when it ends
}

void HrSolver::standInUnopened(Hierarchy& h, const std::vector<uint32_t>& recv,
                               std::vector<Link>& links, HrResult& res,
                               IterationRecord& rec) const {
    if (!linker_ || !linker_->settings().standIn) return;
    Timer t;
    std::vector<size_t> open;
    for (size_t i = 0; i < links.size(); ++i)
        if (links[i].flags & Link::kOpen) open.push_back(i);
    if (open.empty()) return;
    const uint64_t rays = links_.standIns(h, recv, links, open, false);
    countStandIns(res, rec, open.size(), rays, t.seconds(), false);
    spdlog::info(
        "{} links that had to be opened got a stand-in transfer ({} rays, {} samples, {:.1f} s)",
        open.size(), rays, h.standInSampleCount(), t.seconds());
}

void HrSolver::initialLinks(Hierarchy& h, std::vector<uint32_t>& recv, std::vector<Link>& links,
                            HrResult& res, bool progress) {
    // Without clustering every pair of root patches that face each other and
    // are not fully occluded is linked (HSA91 section 3). O(k^2) in the
    // number of patches: the reason for clustering (Smits et al. 1994).
    if (h.numClusters() > 0) {
        // Clustering: the whole scene is one cluster linked to itself
        // (Smits et al. 1994; Sillion 1995); refinement opens it.
        Link self;
        self.sender = h.rootCluster();
        self.K = 0.f;
        self.setUpperF(3.0e38f);
        self.setVis(1.0);
        self.flags = Link::kOpen;
        recv.push_back(h.rootCluster());
        links.push_back(self);
        res.initialPairs = 1;
        return;
    }
    uint32_t k = h.numPatches();
    std::vector<std::vector<Link>> rows(k);
    std::atomic<uint64_t> rays{0}, ffs{0};
    ProgressBar bar("initial linking", k, progress);
    // O(k^2): a signal stops it between receivers; the links made so far are
    // iterated once and the result is marked interrupted (core/stop.h).
    const StopPoll stop = budget_->stopPoll();
    std::atomic<bool> stopped{false};
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, k, 4), [&](const auto& range) {
        for (uint32_t r = range.begin(); r != range.end(); ++r) {
            if (stopped.load(std::memory_order_relaxed) || stop()) {
                stopped = true;
                break;
            }
            uint64_t localRays = 0, localFf = 0;
            if (!included_.empty() && !included_[r]) {
                bar.add(1);
                continue;
            }
            for (uint32_t s = 0; s < k; ++s) {
                if (s == r || (!included_.empty() && !included_[s])) continue;
                uint32_t nr = 0;
                Link l = links_.make(h, r, s, nr);
                localRays += nr;
                ++localFf;
                if (l.K > 0 || links_.keepSurfaceLink(l)) rows[r].push_back(l);
            }
            rays += localRays;
            ffs += localFf;
            bar.add(1);
        }
    });
    bar.done();
    if (stopped) {
        spdlog::warn("signal {} received during initial linking: the links made so far are "
                     "iterated once, and the result is marked interrupted", interruptSignal());
        res.interrupted = true;
    }
    for (uint32_t r = 0; r < k; ++r) {
        for (const Link& l : rows[r]) {
            recv.push_back(r);
            links.push_back(l);
        }
    }
    res.totalRays += rays;
    res.totalFormFactors += ffs;
    res.initialPairs = ffs;
}

uint64_t HrSolver::refine(Hierarchy& h, const oracles::Oracle& oracle, HrResult& res,
                          IterationRecord& rec) {
    // memory.budget_mb (hr/budget.h): what the process holds besides the
    // links and elements (the scene, Embree, the clusters, the libraries, and
    // whatever the allocator kept), measured now.
    const uint64_t rssNow = currentRssBytes(), held = h.elementBytes() + h.linkBytes();
    const uint64_t fixedBytes = rssNow > held ? rssNow - held : 0;
    // The coupling matrices of the links as they are, for the links kept.
    PreviousCoupling previous;
    if (coupling_) previous = snapshotCoupling(h);
    const uint64_t refined = RefinementPass(*this, h, oracle, res, rec, fixedBytes).run();
    if (coupling_) rec.rays += updateCoupling(h, &previous);
    return refined;
}

bool HrSolver::checksAtConvergence(Hierarchy& h, const oracles::Oracle& oracle, HrResult& res) {
    CheckConvergence c{h, oracle, engine_, epsPower_, scene_->emittedPower(), leafCache_};
    bool again = false;
    for (auto& check : checks_) again = check->atConvergence(c) || again;
    res.refineSeconds += c.seconds;
    return again;
}

HrResult HrSolver::solve(bool progress) {
    Timer all;
    HrResult res = solveOnce(progress);
    if (!(s_.noiseTarget > 0.0)) return res;
    const double first = res.noise.relative;
    // The noise is taken to fall as rays^-a: a = 1/2 (each link's variance
    // as 1 / rays) until two solves measure it; a round multiplies the rays
    // by at most kStep, so that a first estimate far off costs one round,
    // not the whole budget.
    constexpr double kStep = 8.0;
    double factor = 1.0, a = 0.5, prevFactor = 0.0, prevNoise = 0.0;
    int rounds = 0;
    while (res.noise.relative > s_.noiseTarget && rounds < s_.noiseRounds) {
        // A solve stopped early is not solved again: more rays would only
        // stop it earlier.
        if (res.stoppedEarly() || res.linkCapHit || res.memoryBudgetHit) break;
        const double noise = res.noise.relative;
        if (prevFactor > 0.0 && prevNoise > noise && noise > 0.0)
            a = std::clamp(std::log(prevNoise / noise) / std::log(factor / prevFactor), 0.25, 2.0);
        const double want = std::pow(noise / s_.noiseTarget, 1.0 / a) * 1.1;
        const double next =
            std::min(s_.noiseMaxFactor, std::ceil(factor * std::min(kStep, want)));
        if (!(next > factor)) {
            spdlog::warn("hr.noise_target {}: the rays may grow by hr.noise_max_factor = {} "
                         "at most, and have",
                         s_.noiseTarget, s_.noiseMaxFactor);
            break;
        }
        if (s_.maxSeconds > 0 && all.seconds() >= s_.maxSeconds) break;
        HrSettings t = s_;
        t.noiseTarget = 0.0;
        if (s_.maxSeconds > 0) t.maxSeconds = std::max(1e-3, s_.maxSeconds - all.seconds());
        auto scaled = [&](int n) { return int(std::min(double(1 << 20), std::ceil(n * next))); };
        t.ff.visRays = scaled(s_.ff.visRays);
        t.clusterLink.visRays = scaled(s_.clusterLink.visRays);
        t.clusterLink.nearRays = scaled(s_.clusterLink.nearRays);
        t.clusterLink.standInRays = scaled(s_.clusterLink.standInRays);
        spdlog::info(
            "hr.noise_target {}: the solve's noise is {:.3g}; solving again with {}x the rays "
            "(ff.vis_rays {}, cluster.vis_rays {})",
            s_.noiseTarget, noise, next, t.ff.visRays, t.clusterLink.visRays);
        res = HrResult{};  // one hierarchy in memory at a time
        HrSolver again(*scene_, *vis_, std::move(t), extraChecks_);
        again.setIterationHook(hook_);
        res = again.solveOnce(progress);
        prevFactor = factor;
        prevNoise = noise;
        factor = next;
        ++rounds;
    }
    if (res.noise.relative > s_.noiseTarget)
        spdlog::warn("hr.noise_target {} not reached: the solve's noise is {:.3g} after {} "
                     "re-solve(s) with {}x the rays",
                     s_.noiseTarget, res.noise.relative, rounds, factor);
    res.noiseRounds = rounds;
    res.noiseRayFactor = factor;
    res.noiseFirst = first;
    res.noiseRoundsSeconds = all.seconds();
    return res;
}

HrResult HrSolver::solveOnce(bool progress) {
    progress_ = progress;
    solveTimer_.reset();
    epsPower_ = emittedPower_;
    HrResult res;
    res.epsPower = epsPower_;
    res.epsPowerOf = s_.epsPower;
    res.minArea = minArea_;
    links_.resetCost();
    buildHierarchy(res);
    Hierarchy& h = *res.hierarchy;
    linkInitially(h, res, progress);
    iterate(h, res, progress);
    res.field = std::make_unique<HierarchyField>(h);
    estimateErrors(h, res);
    summarize(h, res);
    return res;
}

void HrSolver::buildHierarchy(HrResult& res) {
    // cluster.model = auto resolves here, recorded in the result.
    clusterModel_ = s_.clusterModel;
    if (clusterModel_ == cluster::ClusterModel::Auto) {
        clusterModel_ = scene_->patches.size() > cluster::kAutoClusterPatches
                            ? cluster::ClusterModel::Oriented
                            : cluster::ClusterModel::None;
        spdlog::info("cluster.model = auto: {} for {} patches",
                     cluster::clusterModelName(clusterModel_), scene_->patches.size());
    }
    res.clusterModel = cluster::clusterModelName(clusterModel_);
    findReachable(res);
    if (cluster::transferModel(clusterModel_).hasClusters()) {
        PhaseProgress phase("cluster tree", progress_);  // core/phase_progress.h
        res.clusterTree = std::make_unique<cluster::ClusterTree>(*scene_, s_.cluster, included_);
        phase.done();
        res.clusterBuildSeconds = res.clusterTree->buildSeconds();
        spdlog::info(
            "cluster tree ({}{}): {} clusters ({} face clusters, {} planar), depth {}, {:.3f} s",
            s_.cluster.builder, s_.cluster.faces ? " + faces" : "", res.clusterTree->size(),
            res.clusterTree->numFaceNodes(), res.clusterTree->numPlanarFaceNodes(),
            res.clusterTree->depth(), res.clusterBuildSeconds);
    }
    res.hierarchy = std::make_unique<Hierarchy>(*scene_, res.clusterTree.get(), clusterModel_,
                                                s_.basisDegree);
    Hierarchy& h = *res.hierarchy;
    h.setSubdivisionLimits(minArea_, s_.maxLevel);
    h.setElementRho(s_.elementRho);
    h.setJudgedSurfaceVisibility(s_.judgeVisibility);
    h.setSeed(s_.seed);
    linker_ = std::make_unique<cluster::ClusterLinker>(*scene_, res.clusterTree.get(),
                                                       clusterModel_, vis_, s_.clusterLink);
    links_.setLinker(linker_.get());
    // The hand-over the transfer model names (hr/handover.h).
    if (res.clusterTree)
        h.setHandOver(makeHandOver(h.transferModel().handOver(s_.clusterLink),
                                   {scene_, res.clusterTree.get(), vis_, &s_.clusterLink, s_.seed,
                                    progress_}));
    if ((res.openness = h.handOver().opennessTable())) {
        res.opennessRays = res.openness->rays();
        res.opennessSeconds = res.openness->seconds();
        spdlog::info("hand-over openness: {} rays, {:.2f} s, {}", res.opennessRays,
                     res.opennessSeconds, formatBytes(res.openness->memoryBytes()));
    }
}

void HrSolver::findReachable(HrResult& res) {
    included_.clear();
    if (s_.reachRays <= 0 || !scene_->lights.empty()) return;  // traced from patches only
    PhaseProgress phase("reachability", progress_);
    transport::Reachability reach = transport::reachablePatches(
        *scene_, *vis_, s_.reachRays, reseed(1, s_.seed), s_.reachRetryRays);
    phase.done();
    res.unreachablePatches = reach.unreachable;
    res.reachRays = reach.rays;
    res.reachSeconds = reach.seconds;
    // Emitters are always reachable. Without a lit patch there is nothing
    // to leave out (the solution is zero anyway).
    if (reach.unreachable > 0 && reach.unreachable < scene_->patches.size())
        included_ = std::move(reach.reachable);
    spdlog::info(
        "reachability: {} of {} patches cannot be reached by light ({} rays each, {:.2f} s){}",
        reach.unreachable, scene_->patches.size(), s_.reachRays, reach.seconds,
        included_.empty() ? "" : ": left out of the transport");
}

void HrSolver::linkInitially(Hierarchy& h, HrResult& res, bool progress) {
    Timer t;
    {
        std::vector<uint32_t> recv;
        std::vector<Link> links;
        initialLinks(h, recv, links, res, progress);
        h.setLinks(recv, std::move(links));
        res.totalRays += updateCoupling(h, nullptr);
    }
    res.linkingSeconds = t.seconds();
    res.initialLinks = h.numLinks();
    spdlog::info("initial linking: {} links between {} patches ({:.2f} s)", h.numLinks(),
                 h.numPatches(), res.linkingSeconds);
}

/// What the iterations carry from one to the next, across eps stages.
struct HrSolver::LoopState {
    RGB lastReflected;
    /// The power eps is a fraction of (hr.eps_power), from the reflected
    /// power after each iteration.
    EpsPowerTracker epsPower;
    IterationAccelerator accel;
    /// Geometric-tail estimate of the error still to come (solver.h "Stopping").
    IterationTail tail;
    int iteration = 0;
};

void HrSolver::iterate(Hierarchy& h, HrResult& res, bool progress) {
    std::vector<double> stages = s_.epsSchedule;
    Params probe = s_.oracleParams;
    auto probeOracle = oracles::createOracle(s_.oracle, probe);
    // The oracle's eps as set, or its default: a number a stage controller
    // can lower (NaN for an oracle without eps).
    if (stages.empty()) stages.push_back(probeOracle->refinesByError() ? probeOracle->eps() : NAN);
    const RGB reflected = h.reflectedPower();
    LoopState st{reflected, EpsPowerTracker(s_.epsPower, emittedPower_, reflected),
                 IterationAccelerator(s_, h), IterationTail{}, 0};
    res.converged = false;
    for (size_t stage = 0; stage < stages.size(); ++stage) {
        const bool stageConverged = runStage(h, res, int(stage), stages[stage], st, progress);
        res.converged = stageConverged && !res.stoppedEarly();
        if (res.stoppedEarly()) break;
        // After the planned stages a controller may add more (a target error).
        if (stage + 1 == stages.size() && res.converged && stageController_ &&
            !std::isnan(stages.back())) {
            std::optional<double> next = stageController_->afterStage(h, stages.back());
            if (next && *next < stages.back()) stages.push_back(*next);
        }
    }
}

bool HrSolver::runStage(Hierarchy& h, HrResult& res, int stage, double eps, LoopState& st,
                        bool progress) {
    Params op = s_.oracleParams;
    if (!std::isnan(eps)) op.set("eps", eps);
    auto oracle = oracles::createOracle(s_.oracle, op);
    res.oracleDescription = oracle->describe();
    if (!scene_->lights.empty()) {
        if (!lightLinks_ || stage == 0)
            lightLinks_ = std::make_shared<LightLinks>(
                *scene_, *vis_, LightLinkSettings{s_.lightStrata, s_.lightClusters});
        const uint64_t before = lightLinks_->rays();
        lightLinks_->refine(h, *oracle, epsPower_, emittedRadiosity_);
        res.totalRays += lightLinks_->rays() - before;
        res.lightLinks = lightLinks_->numLinks();
    }
    // The radiosities of the last judging pass (lazy refinement); a new
    // stage (a new eps) always judges. A check that must see every iteration
    // (the full leaf budget) turns lazy refinement off; the balanced budget
    // keeps it (its check runs where the stage would converge).
    std::vector<RGB> judgedB;
    bool lazy = s_.refineGrowth > 0.0 && h.basisSize() == 1;
    for (auto& check : checks_) {
        lazy = lazy && !check->judgesEveryIteration();
        check->beginStage();
    }
    // No cap (links, memory, clock) has stopped refinement.
    auto mayRefine = [&] { return !res.linkCapHit && !res.memoryBudgetHit && !outOfTime(); };
    for (int it = 0; it < s_.maxIterations; ++it) {
        // A check holding refinements for this pass (the balanced leaf
        // budget's pushes) makes it a judging pass.
        bool checkPass = false;
        for (auto& check : checks_) checkPass = checkPass || check->wantsPass();
        IterationRecord rec = runIteration(h, *oracle, res, st, lazy, checkPass, judgedB);
        rec.stage = stage;
        rec.eps = eps;
        logIteration(rec, progress);
        if (hook_) hook_(h, rec);
        res.history.push_back(rec);
        if (rec.refinedLinks == 0 && it + 1 >= s_.minIterations &&
            rec.residual < s_.tolerance && rec.iterationError < s_.tolerance) {
            // Where the stage would converge a check may ask for one more
            // judging pass (unless the last such pass refined nothing, or a
            // cap or the clock has stopped refinement).
            if (!checkPass && mayRefine() && checksAtConvergence(h, *oracle, res)) continue;
            return true;
        }
        // After a pass a check asked for, it checks again right after the
        // next gather rather than at the next convergence (the leaf
        // estimate is linear in B, which a push changes little).
        if (checkPass && rec.refinedLinks > 0 && mayRefine()) checksAtConvergence(h, *oracle, res);
        if (outOfTime() && interruptSignal() != 0) {
            if (!res.interrupted)
                spdlog::warn("signal {} received after iteration {}: the solution so far is the "
                             "result, marked interrupted",
                             interruptSignal(), rec.iteration);
            res.interrupted = true;
            return false;
        }
        if (outOfTime()) {
            if (!res.timeLimitHit)
                spdlog::warn(
                    "hr.max_seconds = {} reached after iteration {}: the solution so far is the "
                    "result",
                    s_.maxSeconds, rec.iteration);
            res.timeLimitHit = true;
            return false;
        }
    }
    return false;
}

IterationRecord HrSolver::runIteration(Hierarchy& h, const oracles::Oracle& oracle,
                                       HrResult& res, LoopState& st, bool lazy, bool checkPass,
                                       std::vector<RGB>& judgedB) {
    IterationRecord rec;
    rec.iteration = ++st.iteration;
    Timer tr;
    // The power eps is a fraction of now (hr.eps_power); under smaller and
    // reflected, a fall by more than the growth allowance triggers a
    // judging pass.
    const double powerNow = st.epsPower.power();
    leafCache_.valid = false;
    rec.judged = !lazy || judgedB.empty() || checkPass ||
                 grownSince(h.allB(), judgedB, s_.refineGrowth) ||
                 powerNow * (1.0 + s_.refineGrowth) < epsPower_;
    if (rec.judged) {
        epsPower_ = powerNow;
        res.epsPower = epsPower_;
        rec.refinedLinks = refine(h, oracle, res, rec);
        if (lazy) judgedB = h.allB();
    }
    rec.refineSeconds = tr.seconds();
    gatherOnce(h, rec);
    const bool quiet = IterationAccelerator::quiet(rec.refinedLinks, h.numLinks());
    st.accel.relax(h, quiet, rec, st.lastReflected);
    const RGB reflected =
        st.accel.extrapolate(h, quiet, rec, h.reflectedPower(), st.lastReflected);
    rec.reflectedPower = reflected;
    rec.residual = relativeChange(reflected, st.lastReflected);
    rec.iterationError = st.tail.add(reflected - st.lastReflected, reflected,
                                     rec.refinedLinks > 0 || rec.extrapolation != 0.0
                                         ? IterationTail::Step::kBreak
                                     : rec.relaxIncomplete ? IterationTail::Step::kIrregular
                                                           : IterationTail::Step::kClean);
    st.accel.remember(h);
    st.lastReflected = reflected;
    st.epsPower.add(reflected);
    rec.links = h.numLinks();
    rec.elements = h.numElements();
    rec.leaves = h.numLeaves();
    rec.elementBytes = h.elementBytes();
    rec.linkBytes = h.linkBytes();
    rec.peakRss = peakRssBytes();
    res.totalRays += rec.rays;
    res.totalFormFactors += rec.formFactors;
    res.refineSeconds += rec.refineSeconds;
    res.gatherSeconds += rec.gatherSeconds;
    res.pushPullSeconds += rec.pushPullSeconds;
    return rec;
}

void HrSolver::gatherOnce(Hierarchy& h, IterationRecord& rec) const {
    if (s_.gaussSeidel) {
        h.sweep(s_.gsBlocks > 0 ? s_.gsBlocks : int(std::min<uint32_t>(h.numPatches(), 1u << 30)),
                &rec.gatherSeconds, &rec.pushPullSeconds);
        return;
    }
    Timer tg;
    h.gather();
    rec.gatherSeconds = tg.seconds();
    Timer tp;
    h.pushPull();
    rec.pushPullSeconds = tp.seconds();
}

void HrSolver::logIteration(const IterationRecord& rec, bool progress) const {
    if (!progress) return;
    spdlog::info(
        "iter {:3d}  links {:>10}  elements {:>9}  refined {:>9}  residual {:.3e}  ({:.2f} s)",
        rec.iteration, rec.links, rec.elements,
        rec.judged ? fmt::format("{}", rec.refinedLinks) : std::string("not judged"),
        rec.residual, rec.refineSeconds + rec.gatherSeconds + rec.pushPullSeconds);
    if (rec.relaxedPatches > 0)
        spdlog::info("          relaxed {} patches alone ({} sweeps)", rec.relaxedPatches,
                     rec.relaxSweeps);
}

void HrSolver::estimateErrors(const Hierarchy& h, HrResult& res) const {
    Timer te;
    if (coupling_ && coupling_->fallbacks() > 0)
        spdlog::info(
            "coupling: {} link evaluations kept only the sender's mean (the point-to-point "
            "rule missed the exact form factors by more than hr.basis_check = {})",
            coupling_->fallbacks(), s_.basisCheck);
    const std::vector<uint32_t> recv = h.linkReceivers();
    res.errorEstimate = estimateError(h, recv);
    if (s_.leafEstimates && leafCache_.valid) {
        // The balanced leaf budget's last check saw this very state: its
        // seconds are the estimate's, not refinement's.
        res.refineSeconds -= leafCache_.seconds;
        res.errorEstimateSeconds += leafCache_.seconds;
        const double reflected = luminance(h.reflectedPower());
        res.errorEstimateLeaves = reflected > 0 ? leafCache_.totals.leaves / reflected : 0.0;
        res.errorEstimatePoints = reflected > 0 ? leafCache_.totals.points / reflected : 0.0;
    } else if (s_.leafEstimates) {
        res.errorEstimateLeaves = leafAverageError(
            h, recv, h.links(), engine_, &res.errorEstimatePoints,
            h.hasKernelSamples() && h.basisDegree() == 0 ? &h.kernelSamples() : nullptr);
    }
    res.errorEstimateSeconds += te.seconds();
    Timer tn;
    NoiseRays rays;
    rays.surface = s_.ff.visRays;
    rays.cluster = linker_ ? linker_->settings().visRays : 0;
    // The light of each link, which the noise estimate computes anyway,
    // also gives the share of it that the leaf estimates do not see.
    const bool uncovered = s_.leafEstimates && std::isfinite(res.errorEstimateLeaves);
    std::vector<RGB> light;
    res.noise = estimateNoise(h, rays, uncovered ? &light : nullptr);
    if (uncovered) res.errorEstimateUncovered = uncoveredLightShare(h, recv, light);
    res.noiseSeconds = tn.seconds();
    spdlog::info(
        "the solve's own ray noise: reflected power +-{:.2f} % (1 sd, {} noisy links, "
        "amplification {:.2f}), per patch (direct, non-emitters) {:.2f} %",
        100.0 * res.noise.relative, res.noise.links, maxComponent(res.noise.amplification),
        100.0 * res.noise.l2NonEmitter);
}

void HrSolver::summarize(const Hierarchy& h, HrResult& res) const {
    h.reportMemory(res.memory);  // with the hand-over's (handover_openness, stand_in_handover)
    const HandOver::Counts handOver = h.handOver().counts();
    res.handOverByOpenness = handOver.byOpenness;
    res.handOverByCosine = handOver.byCosine;
    res.handOverCapped = handOver.capped;
    RGB standIn(0.0);  // the light the stand-ins carry: what their receivers reflect of it
    for (uint32_t r = 0; r < h.numElements(); ++r) {
        const bool rc = h.isCluster(r);
        for (uint64_t i = h.linkBegin(r); i < h.linkEnd(r); ++i) {
            const Link& l = h.link(i);
            const bool sc = h.isCluster(l.sender);
            (rc ? (sc ? res.linksCC : res.linksCS) : (sc ? res.linksSC : res.linksSS))++;
            if (l.flags & Link::kOpen) ++res.unopenedLinks;
            if (l.flags & Link::kDeferred) ++res.deferredLinksLeft;
            if (l.flags & Link::kStandIn) {
                standIn += h.standInReflected(r, i);
                ++res.standInLinksFinal;
            }
        }
    }
    if (res.standInLinksFinal > 0) {
        const double reflected = maxComponent(h.reflectedPower());
        res.standInPowerShare = reflected > 0 ? maxComponent(standIn) / reflected : 0.0;
        spdlog::info("stand-in links carry {:.1f} % of the reflected power",
                     100.0 * res.standInPowerShare);
    }
    if (res.unopenedLinks > 0)
        spdlog::warn(
            "{} links that had to be opened were left unopened (refinement stopped early: "
            "hr.max_links, memory.budget_mb or hr.max_seconds) without a stand-in "
            "(cluster.stand_in = false); they carry no light",
            res.unopenedLinks);
    std::string used;
    for (const CheckUse& u : res.checks)
        if (u.passes > 0) used += fmt::format(" {} {}/{}", u.name, u.amended, u.passes);
    if (!used.empty()) spdlog::info("refinement checks (decisions changed / passes):{}", used);
    res.linkCost = links_.cost();
    const LinkKindCost& c = res.linkCost;
    spdlog::info(
        "link evaluations (kept or refined away), rays, CPU s by kind: surface-surface "
        "{} / {} / {:.2f}, surface<-cluster {} / {} / {:.2f}, cluster<-surface {} / "
        "{} / {:.2f}, cluster-cluster {} / {} / {:.2f}",
        c.evaluations[0], c.rays[0], c.seconds[0], c.evaluations[1], c.rays[1], c.seconds[1],
        c.evaluations[2], c.rays[2], c.seconds[2], c.evaluations[3], c.rays[3], c.seconds[3]);
}

}  // namespace hrad::hr
