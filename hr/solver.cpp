#include "hr/solver.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <optional>
#include <sstream>
#include <unordered_map>

#include "core/log.h"
#include "core/memory.h"
#include "core/rng.h"
#include "core/timer.h"
#include "hr/eps_power.h"
#include "hr/iteration_tail.h"
#include "hr/receiver_error.h"
#include "oracles/registry.h"
#include "transport/reachability.h"

namespace hrad::hr {

using oracles::Decision;

namespace {
/// Frees v's storage (clear() keeps it).
template <class T>
void releaseVector(std::vector<T>& v) {
    std::vector<T>().swap(v);
}

/// A link between two surface elements (no cluster on either side).
bool surfacePair(const Hierarchy& h, uint32_t r, uint32_t s) {
    return s != kNone && !h.isCluster(r) && !h.isCluster(s);
}

/// Largest rho_r |B_c - B_s| (max channel) over the children of a subdivided
/// surface sender s; 0 for a leaf or a cluster (LinkEstimate::senderSpread).
double senderSpread(const Hierarchy& h, uint32_t r, uint32_t s) {
    if (h.isCluster(s) || h.firstChild(s) == kNone) return 0.0;
    double spread = 0.0;
    for (uint32_t c = 0; c < h.numChildren(s); ++c)
        spread = std::max(spread, maxComponent(h.rho(r) * glm::abs(h.B(h.child(s, c)) - h.B(s))));
    return spread;
}

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

// A judging pass that refines at most this share of the links leaves its
// iteration quiet for relaxation and extrapolation (header, "Relaxation" and
// "Extrapolation"): with lazy refinement a slowly brightening scene is judged
// every iteration, and on the bathroom 1 to 56 of 1.4 M links were refined in
// most iterations after the first sixteen, which held both back while its
// reflected power still rose by 0.1 % per iteration.
constexpr double kQuietRefinement = 1e-4;

/// The root patches that carry at least `share` of the change of the last
/// two iterations (A_p max_c |B_p - previous_p| plus `lastChange`_p, the
/// same one iteration earlier, which it updates; two iterations, so that both
/// surfaces of a facing pair whose light alternates between them are
/// found), the fewest that do, when they are at most `fraction` of all root
/// patches; empty otherwise. In index order.
std::vector<uint32_t> concentratedChange(const Hierarchy& h, const std::vector<RGB>& previous,
                                         std::vector<double>& lastChange, double share,
                                         double fraction) {
    const uint32_t np = uint32_t(previous.size());
    const uint32_t most = uint32_t(std::min<double>(fraction * double(np), double(np)));
    std::vector<uint32_t> hot;
    lastChange.resize(np, 0.0);
    std::vector<double> d(np);
    double total = 0.0;
    for (uint32_t p = 0; p < np; ++p) {
        const double now = h.area(p) * maxComponent(glm::abs(h.B(p) - previous[p]));
        d[p] = now + lastChange[p];
        lastChange[p] = now;
        total += d[p];
    }
    if (most == 0) return hot;
    if (!(total > 0.0)) return hot;
    std::vector<uint32_t> idx(np);
    for (uint32_t p = 0; p < np; ++p) idx[p] = p;
    auto larger = [&](uint32_t a, uint32_t b) { return d[a] > d[b] || (d[a] == d[b] && a < b); };
    std::nth_element(idx.begin(), idx.begin() + (most - 1), idx.end(), larger);
    idx.resize(most);
    std::sort(idx.begin(), idx.end(), larger);
    double sum = 0.0;
    for (uint32_t p : idx) {
        hot.push_back(p);
        sum += d[p];
        if (sum >= share * total) break;
    }
    if (sum < share * total) hot.clear();
    std::sort(hot.begin(), hot.end());
    return hot;
}

double relativeChange(const RGB& now, const RGB& before) {
    double num = maxComponent(glm::abs(now - before));
    double den = maxComponent(glm::abs(now));
    if (den <= 0) return num > 0 ? 1.0 : 0.0;
    return num / den;
}
}  // namespace

HrSolver::HrSolver(const scene::Scene& scene, const transport::Visibility& visibility,
                   HrSettings settings)
    : scene_(&scene),
      vis_(&visibility),
      s_(std::move(settings)),
      engine_(scene, &visibility, s_.ff),
      links_(engine_, s_.judgeVisibility) {
    minArea_ = s_.minArea > 0 ? s_.minArea : s_.minAreaRel * scene.totalArea();
    emittedPower_ = maxComponent(scene.emittedPower());
    if (!(emittedPower_ > 0)) emittedPower_ = 1.0;
    epsPower_ = emittedPower_;
    emittedRadiosity_ = 0.0;
    for (const auto& patch : scene.patches)
        emittedRadiosity_ = std::max(emittedRadiosity_, maxComponent(patch.emission));
    if (!(emittedRadiosity_ > 0)) emittedRadiosity_ = 1.0;
    if (s_.basisDegree > 0) {
        basis_ = std::make_unique<scene::BasisSet>(s_.basisDegree);
        coupling_ = std::make_unique<transport::CouplingEngine>(
            scene, &visibility, engine_, *basis_,
            s_.basisPoints > 0 ? s_.basisPoints : s_.basisDegree + 2, s_.basisNearLevels,
            s_.basisCheck);
    }
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

uint64_t HrSolver::passPeakBytes(const Hierarchy& h, uint64_t links, uint64_t samples,
                                 uint64_t elements) const {
    // A judging pass moves the links out of the hierarchy and keeps them,
    // with their receivers, as pending and as kept side by side (two Links
    // and two receiver indices per link; the kept arrays are reserved to the
    // pending size), and their kernel samples likewise. On top of that, the
    // larger of what the decisions hold (per link: ReceiverError and
    // SenderTotal of the links that carry samples, the misplaced power, the
    // decision; receiverErrors() transiently three 8-byte indices per
    // surface link) and what the new links' round holds (two 8-byte offsets
    // per link); per element the leaf ranges, the aggregates' offsets and
    // totals. setLinks() (the sort into rows: one more Link per link, and
    // the samples once more) stays below this. Polynomial bases add their
    // coupling matrices.
    const uint64_t coupling =
        coupling_ ? sizeof(uint32_t) + sizeof(float) * uint64_t(h.basisSize() * h.basisSize()) : 0;
    const uint64_t kept = 2 * (sizeof(Link) + sizeof(uint32_t) + coupling);
    const uint64_t decisions = std::max<uint64_t>(
        sizeof(ReceiverError) + sizeof(SenderTotal) + sizeof(double) + 1 + 3 * sizeof(uint64_t),
        2 * sizeof(uint64_t) + 1);
    const uint64_t perElement = 2 * sizeof(RGB) + 2 * sizeof(uint64_t) + sizeof(double) + 8;
    return links * (kept + decisions) + 2 * samples * sizeof(KernelSamples) +
           elements * perElement;
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
        self.Fupper = 3.0e38f;
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
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, k, 4), [&](const auto& range) {
        for (uint32_t r = range.begin(); r != range.end(); ++r) {
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

oracles::LinkEstimate HrSolver::linkEstimate(const Hierarchy& h, uint32_t r, const Link& l,
                                             bool bounds, bool upper) const {
    uint32_t s = l.sender;
    oracles::LinkEstimate e;
    // The two ends of a cluster link, made once (endOf is not cheap).
    std::optional<std::pair<cluster::LinkEnd, cluster::LinkEnd>> ends;
    e.F = l.K;
    double v = l.vis();
    e.visibility = v;
    e.unoccludedF = v > 0 ? l.K / v : l.K;
    e.Fupper = l.Fupper;
    if (s_.judgeVisibility && !h.isCluster(r) && !h.isCluster(s)) {
        // Judged visibility (header): F from the independent estimate; the
        // link keeps the unoccluded F in Fupper, the bound is made here when
        // the oracle reads it.
        e.unoccludedF = l.Fupper;
        if (l.flags & Link::kUncertain)
            e.visibility = cluster::ClusterLinker::blockedVisibilityBound(s_.ff.visRays);
        e.F = e.unoccludedF * e.visibility;
        e.Fupper = e.unoccludedF;
        if (upper) {
            transport::ElementRef er{h.patch(r), h.domain(r), h.stableId(r)};
            transport::ElementRef es{h.patch(s), h.domain(s), h.stableId(s)};
            e.Fupper = std::max(engine_.upperBound(er, es), e.unoccludedF);
        }
    }
    e.partialVisibility = (l.flags & (Link::kPartial | Link::kUncertain)) != 0;
    if (l.flags & Link::kSampled) {
        // A near cluster pair estimated by sampling (cluster/link.h): the
        // judged estimate, receiver factor included, and its error bound (a
        // stand-in's is Hierarchy::standInJudged: its Fupper may hold a
        // sample block).
        e.F = (l.flags & Link::kStandIn) ? h.standInJudged(l) : double(l.Fupper);
        e.unoccludedF = v > 0 ? e.F / v : e.F;
        e.Fupper = e.F * (1.0 + l.uncertainty / 100.0);
        e.partialVisibility = (l.flags & (Link::kPartial | Link::kUncertain)) != 0;
    } else if (h.isCluster(r) || h.isCluster(s)) {
        // A link touching a cluster is judged with its own visibility
        // estimate (Link::visibility), independent of the one in K
        // (LinkBuilder::make), times the unoccluded point approximation.
        ends.emplace(links_.endOf(h, r), links_.endOf(h, s));
        e.unoccludedF = linker_->kernel(ends->first, ends->second);
        if (l.flags & Link::kUncertain) {
            // All judged rays blocked: the oracle sees the unoccluded
            // transfer times the 95 % upper bound of the visibility, so the
            // link is refined (clusters opened) where that much light could
            // matter, and accepted (carrying what K carries) where not.
            e.visibility = linker_->blockedVisibilityBound();
            e.partialVisibility = true;
        }
        e.F = e.visibility * e.unoccludedF;
    }
    e.receiverArea = h.area(r);
    e.senderArea = h.area(s);
    // A cluster's mean radiosity hides its brightest surfaces: a cluster
    // holding a luminaire and the ceiling around it has a mean B several
    // times below the luminaire's, and its point-approximation transfer
    // (centroid distance, visibility of area-sampled points) misjudges the
    // luminaire's light most. Judged with the mean B, such links were
    // accepted and lost light: with the other fixes of this file in place,
    // the mean B still loses 2.8 % of the power on office:2 and 8.3 % on
    // office:4 (eps 1e-3). The oracle sees the largest radiosity of the root
    // patches below a sender cluster (a bound on what any of its surfaces
    // sends, in the spirit of the B_max of error-bounded refinement,
    // Lischinski et al. 1994), so bright clusters are opened until their
    // emitters are linked as surfaces. Gather still uses directionalB().
    e.senderB = h.isCluster(s) ? h.maxB(s) : h.B(s);
    e.receiverRho = h.rho(r);
    e.senderSpread = senderSpread(h, r, s);
    e.receiverIsCluster = h.isCluster(r);
    e.senderIsCluster = h.isCluster(s);
    if (e.receiverIsCluster && h.clusterModel() == cluster::ClusterModel::Oriented &&
        !(l.flags & Link::kSampled)) {
        // The link stores K without the receiver's projected-area
        // fraction (applied per surface when pushing).
        // (Not sampled and a cluster receiver: the ends are known.)
        const cluster::LinkEnd& re = ends->first;
        Vec3 u = ends->second.center - re.center;
        double len = glm::length(u);
        double g = len > 0 ? linker_->projectedFraction(re, u / len) : 1.0;
        e.F *= g;
        e.unoccludedF *= g;
    }
    e.emittedPower = epsPower_;
    e.emittedRadiosity = emittedRadiosity_;
    e.receiverLevel = h.level(r);
    e.senderLevel = h.level(s);
    // The limits of Hierarchy::setSubdivisionLimits (solve).
    e.receiverCanSubdivide = h.canSubdivide(r);
    e.senderCanSubdivide = h.canSubdivide(s);
    if (bounds) links_.fillBounds(h, r, l, e);
    return e;
}

KernelSamples HrSolver::linkSamples(const Hierarchy& h, uint32_t r, uint32_t s) const {
    // A polynomial receiver misses only what its projection misses.
    return coupling_ ? linkResidualSamples(h, *coupling_, r, s)
                     : linkKernelSamples(h, engine_, r, s);
}

std::vector<KernelSamples> HrSolver::computeKernelSamples(const Hierarchy& h,
                                                          const std::vector<uint32_t>& recv,
                                                          const std::vector<Link>& links) const {
    // Compact: one entry per link that carries samples, in link order.
    std::vector<uint64_t> at(links.size() + 1, 0);
    for (size_t i = 0; i < links.size(); ++i)
        at[i + 1] = at[i] + (h.storesKernelSamples(recv[i], links[i]) ? 1 : 0);
    std::vector<KernelSamples> out(at.back(), KernelSamples{});
    tbb::parallel_for(tbb::blocked_range<size_t>(0, links.size(), 256), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i)
            if (at[i + 1] > at[i]) out[at[i]] = linkSamples(h, recv[i], links[i].sender);
    });
    return out;
}

double HrSolver::estimateError(const Hierarchy& h, const std::vector<uint32_t>& recv) const {
    const std::vector<Link>& links = h.links();
    // The cached samples where h holds them (made with the links), the
    // others computed receiver by receiver (those of receivers that cannot
    // subdivide, or all of them for an oracle that did not ask for them).
    const std::vector<KernelSamples> none;
    const std::vector<KernelSamples>& samples = h.hasKernelSamples() ? h.kernelSamples() : none;
    std::vector<ReceiverError> err;
    receiverErrors(h, recv, links, samples, {}, {}, {}, err, coupling_ != nullptr,
                   [&](uint32_t r, uint32_t s) { return linkSamples(h, r, s); });
    double sum = 0.0;
    uint32_t last = kNone;
    // err holds the links that carry samples, in link order.
    size_t k = 0;
    for (size_t i = 0; i < links.size(); ++i) {
        uint32_t r = recv[i];
        const bool carries = h.carriesKernelSamples(r, links[i]);
        const size_t si = carries ? k++ : 0;
        if (h.isCluster(r)) continue;
        if (carries && err[si].range >= 0.0f && r != last) {
            sum += h.area(r) * double(err[si].range) / 4.0;
            last = r;
        }
        sum += h.area(r) * double(links[i].K) * senderSpread(h, r, links[i].sender) / 2.0;
    }
    double reflected = maxComponent(h.reflectedPower());
    return reflected > 0 ? sum / reflected : 0.0;
}

double HrSolver::leafBudgetPower(const oracles::Oracle& oracle) const {
    // The receiver check's eps (hr.receiver_eps, or the oracle's own mapping
    // of its eps to a power fraction: Oracle::receiverCheckEps) of the power
    // eps refers to (hr.eps_power), in luminance like the estimate.
    double leafEps = oracle.receiverCheckEps();
    if (!oracle.needsReceiverError() && s_.receiverEps > 0.0) leafEps = s_.receiverEps;
    if (!(leafEps > 0.0) || s_.oracle == "uniform") return 0.0;
    const RGB emitted = scene_->emittedPower();
    return leafEps * epsPower_ * luminance(emitted) / std::max(maxComponent(emitted), 1e-300);
}

bool HrSolver::leafBudgetCheck(Hierarchy& h, const oracles::Oracle& oracle, HrResult& res) {
    budgetTotalsValid_ = false;
    if (s_.leafBudget != HrSettings::LeafBudget::Balanced || h.basisDegree() != 0) return false;
    // The default budget sums the receiver check's errors: with the check
    // off (hr.receiver_eps = off: bfa and ff as published) it is off too.
    if (!oracle.needsReceiverError() && s_.receiverEps == 0.0) return false;
    const double budget = leafBudgetPower(oracle);
    if (!(budget > 0.0)) return false;
    Timer t0;
    const std::vector<uint32_t> recv = h.linkReceivers();
    std::vector<double> shares;
    budgetTotals_ = leafErrorTotals(h, recv, h.links(), engine_, true,
                                    h.hasKernelSamples() ? &h.kernelSamples() : nullptr, &shares);
    // The leaves' averages may be wrong by eps beyond the error inside them.
    const double allowed = budget + budgetTotals_.inside();
    spdlog::debug("leaf budget: leaves {:.4g}, inside {:.4g}, eps {:.4g} ({:.2f} s)",
                  budgetTotals_.leaves, budgetTotals_.inside(), budget, t0.seconds());
    if (budgetTotals_.leaves > allowed) {
        // Pushes aim at half the budget beyond the inside error: a push
        // removes only part of a receiver's share, and aiming at the limit
        // itself crept towards it one receiver per pass.
        budgetPush_ = leafBudgetMarks(shares, budgetTotals_.leaves - allowed + 0.5 * budget);
        if (!budgetPush_.empty()) {
            res.refineSeconds += t0.seconds();  // a judging pass follows
            return true;
        }
    }
    // Held: the pass is the final estimate's if nothing changes after it.
    budgetTotalsValid_ = true;
    budgetCheckSeconds_ = t0.seconds();
    res.refineSeconds += budgetCheckSeconds_;
    return false;
}

uint64_t HrSolver::refine(Hierarchy& h, const oracles::Oracle& oracle, HrResult& res,
                          IterationRecord& rec) {
    // memory.budget_mb (below): what the process holds besides the links and
    // elements (the scene, Embree, the clusters, the libraries, and whatever
    // the allocator kept), measured now.
    const uint64_t rssNow = currentRssBytes(), held = h.elementBytes() + h.linkBytes();
    const uint64_t fixedBytes = rssNow > held ? rssNow - held : 0;
    std::vector<uint32_t> recv = h.linkReceivers();
    // The coupling matrices of the links as they are, for the links kept.
    PreviousCoupling previous;
    if (coupling_) previous = snapshotCoupling(h);
    // Moved out, not copied: h has no links until setLinks below.
    std::vector<Link> pending = h.takeLinks();
    // Sending clusters' ray end points are drawn by this iteration's B.
    if (linker_) linker_->prepareSenders(h.allB());
    std::vector<uint32_t> finalRecv;
    std::vector<Link> finalLinks;
    finalRecv.reserve(pending.size());
    finalLinks.reserve(pending.size());
    uint64_t refined = 0;
    int round = 0;
    std::vector<uint8_t> decision;
    std::vector<uint8_t> mark;
    const bool bounds = oracle.needsBounds();
    // The eps of the checks added to the oracle's decisions, a fraction of
    // the emitted power: the (stage's) oracle's eps mapped to one
    // (Oracle::receiverCheckEps: bfa, error, kv their eps; ff F_eps / 100).
    // ff's F_eps itself is a form factor: taken as a power fraction it let
    // every stand-in and partially visible cluster link misplace a tenth of
    // the emitted power at F_eps 0.1 (papers/README.md, "ff's clustered
    // solves were dark").
    const double checkEps = oracle.receiverCheckEps();
    // The receiver check for oracles that do not judge the aggregate
    // themselves (guardEps > 0).
    double guardEps = 0.0;
    if (!oracle.needsReceiverError() && s_.oracle != "uniform") {
        if (s_.receiverEps > 0.0)
            guardEps = s_.receiverEps;
        else if (s_.receiverEps < 0.0 && !std::isnan(oracle.receiverCheckEps()))
            guardEps = oracle.receiverCheckEps();  // auto: the (stage's) oracle maps its eps
    }
    const bool aggregate = oracle.needsReceiverError() || guardEps > 0.0;
    std::vector<ReceiverError> rerr;
    // Kernel samples travel with their links (geometry: computed once, when
    // the link is made; the initial links get theirs here). Each array holds
    // those of the links that store samples (Hierarchy::storesKernelSamples),
    // in the order of its link array.
    std::vector<KernelSamples> pendingS, finalS;
    if (aggregate) {
        // Moved out of the hierarchy, not copied: refinement hands them
        // back with the final links (setLinks below).
        pendingS =
            h.hasKernelSamples() ? h.takeKernelSamples() : computeKernelSamples(h, recv, pending);
        finalS.reserve(pendingS.size());
    }
    // hr.leaf_budget: receivers whose links are pushed down this pass. The
    // full budget judges the leaves' error in every pass; the balanced one
    // hands in the marks of its check at convergence (leafBudgetCheck).
    std::vector<uint8_t> push;
    if (s_.leafBudget == HrSettings::LeafBudget::Full && h.basisDegree() == 0) {
        const double budget = leafBudgetPower(oracle);
        if (budget > 0.0) {
            std::vector<double> shares;
            const LeafErrorTotals t =
                leafErrorTotals(h, recv, pending, engine_, false, nullptr, &shares);
            push = leafBudgetMarks(shares, t.leaves - budget);
            spdlog::debug("leaf budget: leaves {:.4g} against {:.4g}, {} pushed", t.leaves,
                          budget, std::count(push.begin(), push.end(), uint8_t(1)));
        }
    } else if (!budgetPush_.empty()) {
        push = std::move(budgetPush_);
        budgetPush_.clear();
    }
    // Moves pending link i (visited in increasing order from i = 0, with
    // cursor k over pendingS) to the final links.
    auto keepPending = [&](size_t i, size_t& k) {
        finalRecv.push_back(recv[i]);
        finalLinks.push_back(pending[i]);
        if (aggregate && h.storesKernelSamples(recv[i], pending[i]))
            finalS.push_back(pendingS[k++]);
    };
    // Advances cursor k past pending link i's samples without keeping them.
    auto skipPending = [&](size_t i, size_t& k) {
        if (aggregate && h.storesKernelSamples(recv[i], pending[i])) ++k;
    };

    while (!pending.empty()) {
        size_t n = pending.size();
        decision.assign(n, 0);
        // Deferred links whose sending cluster now carries light are computed
        // before anything judges them (cluster.defer_dark).
        if (linker_ && linker_->settings().deferDark) {
            std::atomic<uint64_t> rays{0}, computed{0};
            tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const auto& range) {
                uint64_t localRays = 0, localComputed = 0;
                for (size_t i = range.begin(); i != range.end(); ++i) {
                    const uint32_t s = pending[i].sender;
                    if (!(pending[i].flags & Link::kDeferred) || !(maxComponent(h.maxB(s)) > 0))
                        continue;
                    uint32_t nr = 0;
                    pending[i] = links_.make(h, recv[i], s, nr);
                    localRays += nr;
                    ++localComputed;
                }
                rays += localRays;
                computed += localComputed;
            });
            res.totalRays += rays;
            rec.formFactors += computed;
            res.deferredLinksComputed += computed;
        }
        if (outOfTime()) {
            // hr.max_seconds: keep the pending links as they are.
            if (!res.timeLimitHit)
                spdlog::warn(
                    "hr.max_seconds = {} reached: refinement and iteration stop; the "
                    "solution so far is the result",
                    s_.maxSeconds);
            res.timeLimitHit = true;
            for (size_t i = 0, k = 0; i < n; ++i) keepPending(i, k);
            break;
        }
        // cluster.near = stand_in: pairs too close for the point
        // approximation get a stand-in that is judged below before anything
        // is opened (cluster/link.h "Judged stand-ins").
        standInNear(h, recv, pending, res, rec);
        bool capHit = finalLinks.size() + n > s_.maxLinks;
        if (capHit && !res.linkCapHit) {
            res.linkCapHit = true;
            spdlog::warn("hr.max_links = {} reached: refinement stops here", s_.maxLinks);
        }
        std::vector<SenderTotal> stot;
        const bool wantTotals =
            !capHit && s_.senderTotal && (oracle.needsReceiverError() || guardEps > 0.0);
        LeafRanges ranges;
        if (wantTotals || (!capHit && aggregate)) leafRanges(h, ranges);
        if (wantTotals) senderTotals(h, recv, pending, finalRecv, finalLinks, stot, &ranges);
        if (!capHit && aggregate)
            receiverErrors(h, recv, pending, pendingS, finalRecv, finalLinks, finalS, rerr,
                           coupling_ != nullptr, {}, &ranges);
        // Partially visible links into clusters (cluster.partial_receivers):
        // the power each may hand to unseen surfaces of its receiving
        // cluster, and their sum per receiving cluster.
        std::vector<double> misplaced;
        std::vector<double> clusterMisplaced;
        std::vector<uint32_t> clusterPartial;
        const bool nearStandIns = linker_ && linker_->settings().standInNear;
        const bool partialCheck = !capHit && (s_.openPartialReceivers || nearStandIns) &&
                                  checkEps > 0 && h.numClusters() > 0;
        // Filled by the decision pass below, from the estimate it makes
        // anyway; the sums per receiving cluster are taken after it.
        if (partialCheck) misplaced.assign(n, 0.0);
        if (!capHit) {
            // rerr and stot hold the links that carry kernel samples only:
            // each block of links starts at its first such link.
            constexpr size_t kBlock = 1024;
            const size_t blocks = (n + kBlock - 1) / kBlock;
            std::vector<size_t> blockFirst(blocks + 1, 0);
            if (aggregate) {
                for (size_t i = 0; i < n; ++i)
                    if (h.carriesKernelSamples(recv[i], pending[i])) ++blockFirst[i / kBlock + 1];
                for (size_t b = 0; b < blocks; ++b) blockFirst[b + 1] += blockFirst[b];
            }
            const ReceiverError kNotEvaluated{};
            tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks, 1), [&](const auto& range) {
                for (size_t blk = range.begin(); blk != range.end(); ++blk) {
                    size_t k = blockFirst[blk];
                    for (size_t i = blk * kBlock, iEnd = std::min(n, i + kBlock); i < iEnd; ++i) {
                        const bool carries =
                            aggregate && h.carriesKernelSamples(recv[i], pending[i]);
                        const size_t si = carries ? k++ : 0;
                        const Link& l = pending[i];
                        uint32_t r = recv[i], s = l.sender;
                        if (l.flags & Link::kOpen) {
                            decision[i] = uint8_t(links_.forcedDecision(h, r, s));
                            continue;
                        }
                        // A surface link neither of whose ends can subdivide
                        // is kept whatever it is judged to be (every refusal
                        // below goes through oracles::constrain or its like);
                        // finely tessellated scenes have most of their links
                        // there.
                        if (!h.canSubdivide(r) && !h.canSubdivide(s) &&
                            !(l.flags & Link::kSampled)) {
                            decision[i] = uint8_t(Decision::Accept);
                            continue;
                        }
                        // Surface links judged by the receiver aggregate need no
                        // per-link form-factor range (17 contour integrals each).
                        const bool wantBounds = bounds && !(aggregate && surfacePair(h, r, s));
                        oracles::LinkEstimate e =
                            linkEstimate(h, r, l, wantBounds, oracle.needsUpperBound());
                        if (coupling_ && oracle.needsBasisResidual() && surfacePair(h, r, s) &&
                            !(l.flags & Link::kPartial)) {
                            // The part of the transfer the receiver's basis truncates
                            // (oracles/oracle.h LinkEstimate::basisResidualF). Not for
                            // partially visible links: the residual is of the unoccluded
                            // kernel and does not see a shadow edge across the receiver
                            // (judging them by it left cornell's shadows under-refined:
                            // cubic, 2,090 links, L2 0.0060 against 0.0032 with 2,460
                            // links judged by the constant rule), so they keep the
                            // constant rule.
                            transport::ElementRef er{h.patch(r), h.domain(r), h.stableId(r)};
                            transport::ElementRef es{h.patch(s), h.domain(s), h.stableId(s)};
                            e.basisResidualF = coupling_->projectionResidual(er, es) * l.vis();
                        }
                        if (aggregate) {
                            const ReceiverError& re = carries ? rerr[si] : kNotEvaluated;
                            e.receiverRange = re.range;
                            e.receiverDeviation = re.deviation;
                            e.linkDeviation = re.linkDeviation;
                            e.receiverLinks = re.links;
                            if (re.range >= 0.f) {
                                e.senderAggregate = re.senderSum;
                                e.linkSenderPart = re.linkSender;
                            }
                        }
                        if (carries && !stot.empty() && stot[si].total >= 0.f) {
                            e.senderTotal = stot[si].total;
                            e.linkSenderTotal = stot[si].link;
                            e.senderLinks = stot[si].links;
                        }
                        if (partialCheck && h.isCluster(r)) {
                            if (l.byArea()) {
                                // A stand-in whose receiving cluster takes
                                // the light by area may put all of it on the
                                // wrong surfaces.
                                misplaced[i] = maxComponent(e.receiverRho * e.senderB) * e.F *
                                               e.receiverArea;
                            } else if (s_.openPartialReceivers &&
                                       (l.flags & (Link::kPartial | Link::kUncertain))) {
                                const double unseen =
                                    (l.flags & Link::kUncertain) ? 1.0 : 1.0 - e.visibility;
                                misplaced[i] = maxComponent(e.receiverRho * e.senderB) *
                                               (e.visibility > 0 ? e.F / e.visibility : e.F) *
                                               unseen * e.receiverArea;
                            }
                        }
                        Decision d = oracles::constrain(oracle.decide(e), e);
                        // Only the receiver's subdivision lowers its aggregate (the
                        // children of a sender sum to its kernel): a receiver that
                        // cannot subdivide keeps the link (oracles::receiverRefinement).
                        if (d == Decision::Accept && guardEps > 0.0 && e.receiverRange >= 0.0 &&
                            e.receiverRange * e.receiverArea > guardEps * e.emittedPower &&
                            oracles::carriesReceiverShare(e))
                            d = oracles::receiverRefinement(e);
                        if (d == Decision::Accept && r < push.size() && push[r] &&
                            !h.isCluster(r) && !h.isCluster(s) && e.receiverCanSubdivide)
                            d = Decision::RefineReceiver;
                        // The sender side of the same check (hr.sender_total): a
                        // subdivided sender's average, gathered by all its
                        // receivers, within the check's eps share of the power.
                        if (d == Decision::Accept && guardEps > 0.0 &&
                            oracles::senderTotalRefines(e, guardEps))
                            d = oracles::senderRefinement(e);
                        // A sampled near cluster link the oracle accepts must also
                        // be known well enough: the power it may carry wrongly
                        // (its error bound) within the oracle's eps share.
                        if (d == Decision::Accept && (l.flags & Link::kSampled) && checkEps > 0 &&
                            maxComponent(e.receiverRho * e.senderB) * e.F *
                                    (l.uncertainty / 100.0) * e.receiverArea >
                                checkEps * e.emittedPower)
                            d = links_.forcedDecision(h, r, s);
                        // An accepted link that may misplace light
                        // (misplaced > 0) is checked after this pass, when
                        // the sums per receiving cluster are known.
                        if (d == Decision::Accept && partialCheck && misplaced[i] > 0) {
                            decision[i] = uint8_t(d);
                            continue;
                        }
                        // A refused stand-in (or sampled link that found nothing)
                        // of a pair too close for the point approximation is
                        // opened on the side its geometry asks for.
                        if (d != Decision::Accept && nearStandIns && (l.flags & Link::kSampled)) {
                            const Decision f = links_.forcedDecision(h, r, s);
                            if (f != Decision::Accept) d = f;
                        }
                        decision[i] = uint8_t(d);
                    }
                }
            });
            if (partialCheck) {
                // A partially visible (or all-blocked) link into a cluster
                // hands its light to every surface of the cluster that faces
                // the sender, seen or not: up to the unseen fraction of its
                // power lands on the wrong surfaces (closed cavities, the far
                // side of a table). That power must be within eps too, else
                // the receiving cluster is opened (cluster.partial_receivers
                // = open). The links into one cluster misplace light together
                // (as a receiver's averaged senders do, hr/receiver_error.h):
                // their sum is held to eps too, refining the links with at
                // least an even share of it.
                clusterMisplaced.assign(h.numClusters(), 0.0);
                clusterPartial.assign(h.numClusters(), 0);
                for (size_t i = 0; i < n; ++i)
                    if (misplaced[i] > 0) {
                        clusterMisplaced[h.clusterIndex(recv[i])] += misplaced[i];
                        ++clusterPartial[h.clusterIndex(recv[i])];
                    }
                const double limit = checkEps * epsPower_;
                tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const auto& range) {
                    for (size_t i = range.begin(); i != range.end(); ++i) {
                        if (!(misplaced[i] > 0) || Decision(decision[i]) != Decision::Accept)
                            continue;
                        const uint32_t r = recv[i], s = pending[i].sender;
                        const uint32_t c = h.clusterIndex(r);
                        if (!(misplaced[i] > limit ||
                              (clusterMisplaced[c] > limit &&
                               misplaced[i] * clusterPartial[c] >= clusterMisplaced[c])))
                            continue;
                        oracles::LinkEstimate sides;
                        sides.receiverCanSubdivide = h.canSubdivide(r);
                        sides.senderCanSubdivide = h.canSubdivide(s);
                        Decision d = oracles::constrain(Decision::RefineReceiver, sides);
                        // As for every refused sampled link above.
                        if (d != Decision::Accept && nearStandIns &&
                            (pending[i].flags & Link::kSampled)) {
                            const Decision f = links_.forcedDecision(h, r, s);
                            if (f != Decision::Accept) d = f;
                        }
                        decision[i] = uint8_t(d);
                    }
                });
            }
        }
        // What the decisions needed is freed before the next round's links
        // are made (the largest arrays of a round otherwise coexist).
        releaseVector(rerr);
        releaseVector(ranges.lo);
        releaseVector(ranges.hi);
        releaseVector(stot);
        releaseVector(misplaced);
        releaseVector(clusterMisplaced);
        releaseVector(clusterPartial);
        // Collect the elements to subdivide and subdivide them in index order.
        mark.assign(h.numElements(), 0);
        size_t newCount = 0;
        std::vector<size_t> offset(n + 1, 0);
        for (size_t i = 0, k = 0; i < n; ++i) {
            auto d = Decision(decision[i]);
            size_t c = 0;
            if (d == Decision::Accept) {
                keepPending(i, k);
            } else {
                skipPending(i, k);
                bool rr = d == Decision::RefineReceiver || d == Decision::RefineBoth;
                bool ss = d == Decision::RefineSender || d == Decision::RefineBoth;
                uint32_t r = recv[i], s = pending[i].sender;
                if (rr && !h.isCluster(r)) mark[r] = 1;
                if (ss && !h.isCluster(s)) mark[s] = 1;
                size_t nr = rr ? (h.isCluster(r) ? h.numChildren(r) : 4) : 1;
                size_t ns = ss ? (h.isCluster(s) ? h.numChildren(s) : 4) : 1;
                c = nr * ns;
                ++refined;
            }
            offset[i + 1] = offset[i] + c;
        }
        newCount = offset[n];
        if (newCount == 0) break;
        // A stop before the round is made: the links to be refined are kept
        // as they are (the accepted ones are already kept).
        auto keepRefined = [&] {
            for (size_t i = 0, k = 0; i < n; ++i) {
                if (Decision(decision[i]) == Decision::Accept)
                    skipPending(i, k);
                else
                    keepPending(i, k);
            }
        };
        // The hierarchy's own limit (32-bit row offsets), checked with the
        // round's exact count before it is made: like hr.max_links.
        if (finalLinks.size() + n + newCount > Hierarchy::kMaxLinks) {
            if (!res.linkCapHit)
                spdlog::warn("{} links would pass the hierarchy's limit of {}: refinement "
                             "stops here",
                             finalLinks.size() + n + newCount, Hierarchy::kMaxLinks);
            res.linkCapHit = true;
            keepRefined();
            break;
        }
        // Memory budget, checked before allocating the round: the process's
        // peak until the next round is checked, which is the next judging
        // pass over the links of this round and of the next one
        // (passPeakBytes). Past it, the links still to be refined are kept
        // as they are (a coarser solution, flagged).
        if (s_.memoryBudget > 0) {
            uint64_t marked = 0;
            for (uint8_t m : mark) marked += m;
            // Kernel samples for the new links in the share the links so far
            // carry them.
            const uint64_t samplesNow = finalS.size() + pendingS.size();
            const uint64_t newSamples = samplesNow == 0
                                            ? 0
                                            : uint64_t(double(newCount) * double(samplesNow) /
                                                       double(finalLinks.size() + n));
            const uint64_t perElement = h.numElements() ? h.elementBytes() / h.numElements() : 64;
            // This round: the kept, the pending and the new links side by
            // side, with the pending links' two offsets; then the next pass
            // over the links kept and made (finalLinks already holds this
            // round's accepted ones, finalS their samples).
            const uint64_t round =
                (finalLinks.size() + n + newCount) * (sizeof(Link) + sizeof(uint32_t)) +
                n * (2 * sizeof(size_t) + 1) + (samplesNow + newSamples) * sizeof(KernelSamples);
            const uint64_t next = passPeakBytes(h, finalLinks.size() + newCount,
                                                finalS.size() + newSamples, h.numElements() + 4 * marked);
            const uint64_t estimate =
                fixedBytes + h.elementBytes() + 4 * marked * perElement + std::max(round, next);
            // A thirty-second of the budget is kept for what the estimate
            // leaves out (the allocator's own overhead, per-thread buffers):
            // without it the bathroom's peak passed a 700 MiB budget by
            // 0.5-1.5 % (bench/results/large_scenes.md).
            if (estimate > s_.memoryBudget - s_.memoryBudget / 32) {
                if (!res.memoryBudgetHit)
                    spdlog::warn(
                        "memory.budget_mb = {} reached (refinement would need about {}): "
                        "refinement stops here; the solution is coarser than the oracle asks",
                        s_.memoryBudget >> 20, formatBytes(estimate));
                res.memoryBudgetHit = true;
                keepRefined();
                break;
            }
        }
        {
            size_t marked = 0;
            for (uint32_t e = 0; e < uint32_t(mark.size()); ++e)
                marked += (mark[e] && h.firstChild(e) == kNone) ? 1 : 0;
            h.reserveElements(4 * marked);
        }
        for (uint32_t e = 0; e < uint32_t(mark.size()); ++e)
            if (mark[e]) h.subdivide(e);

        // Links between the children, with their form factors (parallel;
        // each slot is written by exactly one task).
        std::vector<uint32_t> nrecv(newCount);
        std::vector<Link> nlinks(newCount);
        // fn(rc, sc) for each child pair that replaces refined link i, in
        // the order of its slots offset[i] .. offset[i + 1].
        auto forEachChildPair = [&](size_t i, auto&& fn) {
            auto d = Decision(decision[i]);
            uint32_t r = recv[i], s = pending[i].sender;
            bool rr = d == Decision::RefineReceiver || d == Decision::RefineBoth;
            bool ss = d == Decision::RefineSender || d == Decision::RefineBoth;
            uint32_t na = rr ? h.numChildren(r) : 1, nb = ss ? h.numChildren(s) : 1;
            for (uint32_t a = 0; a < na; ++a)
                for (uint32_t b = 0; b < nb; ++b)
                    fn(rr ? h.child(r, a) : r, ss ? h.child(s, b) : s);
        };
        // A child pair of two surface elements gets kernel samples when the
        // receiver can subdivide (Hierarchy::storesKernelSamples); a surface
        // self-pair makes no link (below) and none.
        auto childSampled = [&](uint32_t rc, uint32_t sc) {
            return rc != sc && surfacePair(h, rc, sc) && h.canSubdivide(rc);
        };
        // Where each refined link's children put their samples.
        std::vector<size_t> sampleOffset(aggregate ? n + 1 : 0, 0);
        if (aggregate) {
            for (size_t i = 0; i < n; ++i) {
                size_t c = 0;
                if (offset[i + 1] > offset[i])
                    forEachChildPair(i,
                                     [&](uint32_t rc, uint32_t sc) { c += childSampled(rc, sc); });
                sampleOffset[i + 1] = sampleOffset[i] + c;
            }
        }
        std::vector<KernelSamples> nS(aggregate ? sampleOffset[n] : 0);
        std::atomic<uint64_t> rays{0};
        // Each round of a large first refinement can take minutes: its own
        // progress bar (drawn only past a second) with the time left.
        ++round;
        ProgressBar bar(fmt::format("iter {} round {}: {} links", rec.iteration, round, newCount),
                        n, progress_);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const auto& range) {
            uint64_t localRays = 0;
            for (size_t i = range.begin(); i != range.end(); ++i) {
                if (offset[i + 1] == offset[i]) continue;
                size_t o = offset[i];
                size_t so = aggregate ? sampleOffset[i] : 0;
                forEachChildPair(i, [&](uint32_t rc, uint32_t sc) {
                    uint32_t nr = 0;
                    // A self-link between surfaces carries nothing (planar
                    // patches); between clusters it is kept, to be opened.
                    nlinks[o] = rc == sc && !h.isCluster(rc) ? Link{} : links_.make(h, rc, sc, nr);
                    nrecv[o] = rc;
                    if (aggregate && childSampled(rc, sc)) {
                        // Samples only for links that carry light (the others
                        // are dropped below, or kept for the oracle with zero
                        // samples).
                        if (nlinks[o].K > 0) nS[so] = linkSamples(h, rc, sc);
                        ++so;
                    }
                    localRays += nr;
                    ++o;
                });
            }
            rays += localRays;
            bar.add(range.size());
        });
        bar.done();
        rec.rays += rays;
        rec.formFactors += newCount;
        // Drop links that carry nothing (back-facing or fully occluded pairs).
        size_t w = 0, ws = 0, rs = 0;
        // Links to be opened (kOpen), cluster links whose judged rays were
        // all (kUncertain) or partly (kPartial) blocked, and deferred links
        // (kDeferred, computed later) are kept whatever their independent K
        // carries: the oracle still judges them.
        for (size_t i = 0; i < newCount; ++i) {
            bool clusterLink = h.isCluster(nrecv[i]) ||
                               (nlinks[i].sender != kNone && h.isCluster(nlinks[i].sender));
            bool keep = clusterLink ? (nlinks[i].flags & (Link::kOpen | Link::kUncertain |
                                                          Link::kPartial | Link::kDeferred)) != 0
                                    : links_.keepSurfaceLink(nlinks[i]);
            const bool sampled = aggregate && h.storesKernelSamples(nrecv[i], nlinks[i]);
            const size_t si = sampled ? rs++ : 0;
            if (!(nlinks[i].K > 0) && !keep) continue;
            nlinks[w] = nlinks[i];
            nrecv[w] = nrecv[i];
            if (sampled) nS[ws++] = nS[si];
            ++w;
        }
        HRAD_CHECK(rs == nS.size());
        nlinks.resize(w);
        nrecv.resize(w);
        if (aggregate) nS.resize(ws);
        pending = std::move(nlinks);
        recv = std::move(nrecv);
        pendingS = std::move(nS);
    }
    // Refinement stopped early: the links it was about to open get a
    // stand-in transfer instead of none (cluster/link.h "Stand-ins").
    if (res.linkCapHit || res.memoryBudgetHit || res.timeLimitHit)
        standInUnopened(h, finalRecv, finalLinks, res, rec);
    if (aggregate)
        h.setLinks(finalRecv, std::move(finalLinks), std::move(finalS));
    else
        h.setLinks(finalRecv, std::move(finalLinks));
    if (coupling_) rec.rays += updateCoupling(h, &previous);
    return refined;
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
        if (res.timeLimitHit || res.linkCapHit || res.memoryBudgetHit) break;
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
        HrSolver again(*scene_, *vis_, std::move(t));
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
    if (s_.clusterModel == cluster::ClusterModel::Auto) {
        s_.clusterModel = scene_->patches.size() > cluster::kAutoClusterPatches
                              ? cluster::ClusterModel::Oriented
                              : cluster::ClusterModel::None;
        spdlog::info("cluster.model = auto: {} for {} patches",
                     cluster::clusterModelName(s_.clusterModel), scene_->patches.size());
    }
    res.clusterModel = cluster::clusterModelName(s_.clusterModel);
    included_.clear();
    if (s_.reachRays > 0) {
        transport::Reachability reach = transport::reachablePatches(
            *scene_, *vis_, s_.reachRays, reseed(1, s_.seed), s_.reachRetryRays);
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
    if (s_.clusterModel != cluster::ClusterModel::None) {
        res.clusterTree = std::make_unique<cluster::ClusterTree>(*scene_, s_.cluster, included_);
        res.clusterBuildSeconds = res.clusterTree->buildSeconds();
        spdlog::info(
            "cluster tree ({}{}): {} clusters ({} face clusters, {} planar), depth {}, {:.3f} s",
            s_.cluster.builder, s_.cluster.faces ? " + faces" : "", res.clusterTree->size(),
            res.clusterTree->numFaceNodes(), res.clusterTree->numPlanarFaceNodes(),
            res.clusterTree->depth(), res.clusterBuildSeconds);
    }
    res.hierarchy = std::make_unique<Hierarchy>(*scene_, res.clusterTree.get(), s_.clusterModel,
                                                s_.basisDegree);
    Hierarchy& h = *res.hierarchy;
    h.setSubdivisionLimits(minArea_, s_.maxLevel);
    h.setJudgedSurfaceVisibility(s_.judgeVisibility);
    h.setSeed(s_.seed);
    linker_ = std::make_unique<cluster::ClusterLinker>(*scene_, res.clusterTree.get(),
                                                       s_.clusterModel, vis_, s_.clusterLink);
    links_.setLinker(linker_.get());
    if (res.clusterTree && h.clusterModel() == cluster::ClusterModel::Oriented &&
        s_.clusterLink.visibleHandover) {
        res.openness =
            std::make_unique<cluster::SurfaceOpenness>(*scene_, *res.clusterTree, *vis_, s_.seed);
        res.opennessRays = res.openness->rays();
        res.opennessSeconds = res.openness->seconds();
        h.setOpenness(res.openness.get());
        h.setSeenHandOver(s_.clusterLink.standInSeen ? vis_ : nullptr);
        spdlog::info("hand-over openness: {} rays, {:.2f} s, {}", res.opennessRays,
                     res.opennessSeconds, formatBytes(res.openness->memoryBytes()));
    }

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

    std::vector<double> stages = s_.epsSchedule;
    bool hasEps = s_.oracle != "uniform";
    if (stages.empty()) stages.push_back(hasEps ? s_.oracleParams.getDouble("eps", NAN) : NAN);

    RGB lastReflected = h.reflectedPower();
    // The power eps is a fraction of (hr.eps_power), from the reflected
    // power after each iteration.
    EpsPowerTracker epsPower(s_.epsPower, emittedPower_, lastReflected);
    int iteration = 0;
    // Aitken extrapolation state (hr.extrapolate): B one iteration earlier,
    // the last change of reflected power and its ratio, per channel.
    std::vector<RGB> previousB, previousHi;
    RGB lastChange(0.0), lastRatio(0.0);
    // Geometric-tail estimate of the error still to come (solver.h "Stopping").
    IterationTail tail;
    int quietIterations = 0, sinceExtrapolation = 2;
    // Relaxation (hr.relax_share): the root patches' radiosities after the
    // previous iteration.
    const uint32_t np = uint32_t(scene_->patches.size());
    const bool relaxOn =
        s_.relaxShare > 0.0 && h.basisSize() == 1 && uint64_t(s_.relaxFraction * double(np)) > 0;
    std::vector<RGB> prevRoots;
    std::vector<double> prevRootChange;
    res.converged = false;
    for (size_t stage = 0; stage < stages.size(); ++stage) {
        Params op = s_.oracleParams;
        if (!std::isnan(stages[stage])) op.set("eps", stages[stage]);
        auto oracle = oracles::createOracle(s_.oracle, op);
        res.oracleDescription = oracle->describe();
        bool stageConverged = false;
        // The radiosities of the last judging pass (lazy refinement); a new
        // stage (a new eps) always judges.
        std::vector<RGB> judgedB;
        // The full leaf budget judges every iteration; the balanced one keeps
        // lazy refinement (its check runs where the stage would converge).
        const bool lazy = s_.refineGrowth > 0.0 && h.basisSize() == 1 &&
                          s_.leafBudget != HrSettings::LeafBudget::Full;
        budgetPush_.clear();
        // No cap (links, memory, clock) has stopped refinement.
        auto mayRefine = [&] {
            return !res.linkCapHit && !res.memoryBudgetHit && !outOfTime();
        };
        for (int it = 0; it < s_.maxIterations; ++it) {
            IterationRecord rec;
            rec.iteration = ++iteration;
            rec.stage = int(stage);
            rec.eps = stages[stage];
            Timer tr;
            // The power eps is a fraction of now (hr.eps_power); under
            // smaller and reflected, a fall by more than the growth
            // allowance triggers a judging pass.
            const double powerNow = epsPower.power();
            const bool budgetPass = !budgetPush_.empty();
            budgetTotalsValid_ = false;
            rec.judged = !lazy || judgedB.empty() || budgetPass ||
                         grownSince(h.allB(), judgedB, s_.refineGrowth) ||
                         powerNow * (1.0 + s_.refineGrowth) < epsPower_;
            if (rec.judged) {
                epsPower_ = powerNow;
                res.epsPower = epsPower_;
                rec.refinedLinks = refine(h, *oracle, res, rec);
                if (lazy) judgedB = h.allB();
            }
            rec.refineSeconds = tr.seconds();
            if (s_.gaussSeidel) {
                h.sweep(s_.gsBlocks > 0 ? s_.gsBlocks
                                        : int(std::min<uint32_t>(h.numPatches(), 1u << 30)),
                        &rec.gatherSeconds, &rec.pushPullSeconds);
            } else {
                Timer tg;
                h.gather();
                rec.gatherSeconds = tg.seconds();
                Timer tp;
                h.pushPull();
                rec.pushPullSeconds = tp.seconds();
            }
            // A refinement of at most kQuietRefinement of the links leaves
            // the iteration quiet: relaxation and extrapolation go on.
            const bool quiet = rec.refinedLinks == 0 ||
                               double(rec.refinedLinks) <= kQuietRefinement * double(h.numLinks());
            // Relaxation of the few patches that carry most of the change
            // (the change history restarts after a refinement that is not
            // quiet).
            if (!quiet) prevRootChange.clear();
            if (relaxOn && quiet && prevRoots.size() == np) {
                std::vector<uint32_t> hot = concentratedChange(h, prevRoots, prevRootChange,
                                                               s_.relaxShare, s_.relaxFraction);
                if (!hot.empty()) {
                    Timer tx;
                    // A tenth of the tolerance, in power (the last
                    // iteration's reflected power sets the scale).
                    const double target =
                        0.1 * s_.tolerance * maxComponent(glm::abs(lastReflected));
                    Hierarchy::RelaxResult rx = h.relax(
                        hot, s_.relaxSweeps, std::max<uint64_t>(h.iterationLinkReads(), 1), target);
                    rec.gatherSeconds += tx.seconds();
                    if (rx.sweeps > 0) {
                        rec.relaxedPatches = uint32_t(hot.size());
                        rec.relaxSweeps = rx.sweeps;
                        // A relaxation that did not reach its target leaves
                        // the sequence irregular: the tail estimate takes the
                        // slowest step of its window, and no extrapolation
                        // follows right after it.
                        rec.relaxIncomplete = !rx.reached;
                        if (rec.relaxIncomplete) sinceExtrapolation = 0;
                    }
                }
            }
            RGB reflected = h.reflectedPower();
            if (s_.extrapolate) {
                RGB change = reflected - lastReflected, ratio(0.0), factor(0.0);
                quietIterations = quiet ? quietIterations + 1 : 0;
                bool ok = quietIterations >= 2 && sinceExtrapolation >= 2 &&
                          previousB.size() == h.allB().size();
                for (int c = 0; c < 3; ++c) {
                    ratio[c] = lastChange[c] != 0.0 ? change[c] / lastChange[c] : 0.0;
                    bool stable = ratio[c] > 0.0 && ratio[c] < 0.99999 &&
                                  std::fabs(ratio[c] - lastRatio[c]) <= 0.05 * ratio[c];
                    // A channel whose power no longer changes needs nothing.
                    if (change[c] == 0.0) continue;
                    if (!stable) ok = false;
                    factor[c] = ratio[c] / (1.0 - ratio[c]);
                }
                lastRatio = ratio;
                lastChange = change;
                ++sinceExtrapolation;
                if (ok && maxComponent(factor) > 0.0) {
                    if (h.basisSize() > 1)
                        h.extrapolateLeaves(previousB, previousHi, factor);
                    else
                        h.extrapolateLeaves(previousB, factor);
                    rec.extrapolation = maxComponent(factor);
                    sinceExtrapolation = 0;
                    // The extrapolated state starts a new geometric sequence.
                    lastChange = h.reflectedPower() - lastReflected;
                    lastRatio = RGB(0.0);
                    reflected = h.reflectedPower();
                }
                previousB = h.allB();
                if (h.basisSize() > 1) previousHi = h.allHi();
            }
            rec.reflectedPower = reflected;
            rec.residual = relativeChange(reflected, lastReflected);
            rec.iterationError = tail.add(reflected - lastReflected, reflected,
                                          rec.refinedLinks > 0 || rec.extrapolation != 0.0
                                              ? IterationTail::Step::kBreak
                                          : rec.relaxIncomplete ? IterationTail::Step::kIrregular
                                                                : IterationTail::Step::kClean);
            if (relaxOn) {
                prevRoots.resize(np);
                for (uint32_t p = 0; p < np; ++p) prevRoots[p] = h.B(p);
            }
            lastReflected = reflected;
            epsPower.add(reflected);
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
            if (progress)
                spdlog::info(
                    "iter {:3d}  links {:>10}  elements {:>9}  refined {:>9}  residual {:.3e}  "
                    "({:.2f} s)",
                    rec.iteration, rec.links, rec.elements,
                    rec.judged ? fmt::format("{}", rec.refinedLinks) : std::string("not judged"),
                    rec.residual, rec.refineSeconds + rec.gatherSeconds + rec.pushPullSeconds);
            if (progress && rec.relaxedPatches > 0)
                spdlog::info("          relaxed {} patches alone ({} sweeps)", rec.relaxedPatches,
                             rec.relaxSweeps);
            if (hook_) hook_(h, rec);
            res.history.push_back(rec);
            if (rec.refinedLinks == 0 && it + 1 >= s_.minIterations &&
                rec.residual < s_.tolerance && rec.iterationError < s_.tolerance) {
                // The balanced leaf budget: where the stage would converge,
                // the leaves' error is held to its budget; a pass that pushes
                // links follows (unless the last push refined nothing, or a
                // cap or the clock has stopped refinement).
                if (!budgetPass && mayRefine() && leafBudgetCheck(h, *oracle, res)) continue;
                stageConverged = true;
                break;
            }
            // Once the budget has pushed links, it checks again right after
            // the next gather rather than at the next convergence (the
            // estimate is linear in B, which a push changes little): one
            // round of pushes follows another until the budget holds.
            if (budgetPass && rec.refinedLinks > 0 && mayRefine()) leafBudgetCheck(h, *oracle, res);
            if (outOfTime()) {
                if (!res.timeLimitHit)
                    spdlog::warn(
                        "hr.max_seconds = {} reached after iteration {}: the solution so "
                        "far is the result",
                        s_.maxSeconds, rec.iteration);
                res.timeLimitHit = true;
                break;
            }
        }
        res.converged = stageConverged && !res.timeLimitHit;
        if (res.timeLimitHit) break;
    }
    res.field = std::make_unique<HierarchyField>(h);
    Timer te;
    if (coupling_ && coupling_->fallbacks() > 0)
        spdlog::info(
            "coupling: {} link evaluations kept only the sender's mean (the point-to-point "
            "rule missed the exact form factors by more than hr.basis_check = {})",
            coupling_->fallbacks(), s_.basisCheck);
    const std::vector<uint32_t> recv = h.linkReceivers();
    res.errorEstimate = estimateError(h, recv);
    if (s_.leafEstimates && budgetTotalsValid_) {
        // The balanced leaf budget's last check saw this very state: its
        // seconds are the estimate's, not refinement's.
        res.refineSeconds -= budgetCheckSeconds_;
        res.errorEstimateSeconds += budgetCheckSeconds_;
        const double reflected = luminance(h.reflectedPower());
        res.errorEstimateLeaves = reflected > 0 ? budgetTotals_.leaves / reflected : 0.0;
        res.errorEstimatePoints = reflected > 0 ? budgetTotals_.points / reflected : 0.0;
    } else if (s_.leafEstimates) {
        res.errorEstimateLeaves = leafAverageError(
            h, recv, h.links(), engine_, &res.errorEstimatePoints,
            h.hasKernelSamples() && h.basisDegree() == 0 ? &h.kernelSamples() : nullptr);
    }
    res.errorEstimateSeconds += te.seconds();
    {
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
    h.reportMemory(res.memory);
    if (res.openness) res.memory.set("handover_openness", res.openness->memoryBytes());
    res.handOverByOpenness = h.handOverByOpenness();
    res.handOverByCosine = h.handOverByCosine();
    res.handOverCapped = h.handOverCapped();
    RGB standIn(0.0);  // the light the stand-ins carry: what their receivers reflect of it
    for (uint32_t r = 0; r < h.numElements(); ++r) {
        bool rc = h.isCluster(r);
        for (uint64_t i = h.linkBegin(r); i < h.linkEnd(r); ++i) {
            const Link& l = h.link(i);
            bool sc = h.isCluster(l.sender);
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
        double reflected = maxComponent(h.reflectedPower());
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
    res.linkCost = links_.cost();
    {
        const LinkKindCost& c = res.linkCost;
        spdlog::info(
            "link evaluations (kept or refined away), rays, CPU s by kind: surface-surface "
            "{} / {} / {:.2f}, surface<-cluster {} / {} / {:.2f}, cluster<-surface {} / "
            "{} / {:.2f}, cluster-cluster {} / {} / {:.2f}",
            c.evaluations[0], c.rays[0], c.seconds[0], c.evaluations[1], c.rays[1], c.seconds[1],
            c.evaluations[2], c.rays[2], c.seconds[2], c.evaluations[3], c.rays[3], c.seconds[3]);
    }
    return res;
}

}  // namespace hrad::hr
