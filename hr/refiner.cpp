#include "hr/refiner.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>

#include "core/log.h"
#include "hr/checks/check.h"

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

bool refinesReceiver(Decision d) { return d == Decision::RefineReceiver || d == Decision::RefineBoth; }
bool refinesSender(Decision d) { return d == Decision::RefineSender || d == Decision::RefineBoth; }
}  // namespace

RefinementPass::RefinementPass(HrSolver& solver, Hierarchy& h, const oracles::Oracle& oracle,
                               HrResult& res, IterationRecord& rec, uint64_t fixedBytes)
    : solver_(solver),
      h_(h),
      oracle_(oracle),
      res_(res),
      rec_(rec),
      s_(solver.s_),
      fixedBytes_(fixedBytes) {}

uint64_t RefinementPass::run() {
    begin();
    const RefinementBudget& budget = *solver_.budget_;
    while (!pending_.empty()) {
        const size_t n = pending_.size();
        decision_.assign(n, 0);
        computeDeferred();
        if (budget.stopForTime(res_)) {
            for (size_t i = 0, k = 0; i < n; ++i) keepPending(i, k);
            break;
        }
        // cluster.near = stand_in: pairs too close for the point
        // approximation get a stand-in that is judged below before anything
        // is opened (cluster/link.h "Judged stand-ins").
        solver_.standInNear(h_, recv_, pending_, res_, rec_);
        judgeRound(budget.linkCapHit(finalLinks_.size(), n, res_));
        uint64_t marked = 0;
        const std::vector<size_t> offset = markRound(marked);
        if (offset[n] == 0) break;
        RoundSize size{finalLinks_.size(), n, offset[n], finalS_.size() + pendingS_.size(),
                       finalS_.size(), marked};
        if (!budget.roundFits(h_, size, fixedBytes_, res_)) {
            keepRefined();
            break;
        }
        subdivide();
        linkChildren(offset);
        dropEmpty();
    }
    finish();
    return refined_;
}

void RefinementPass::begin() {
    // Moved out, not copied: h has no links until finish().
    recv_ = h_.linkReceivers();
    pending_ = h_.takeLinks();
    // Sending clusters' ray end points are drawn by this iteration's B.
    if (solver_.linker_) solver_.linker_->prepareSenders(h_.allB());
    finalRecv_.reserve(pending_.size());
    finalLinks_.reserve(pending_.size());
    bounds_ = oracle_.needsBounds();
    // The eps of the checks, a fraction of the eps power: the (stage's)
    // oracle's eps mapped to one (Oracle::receiverCheckEps: bfa, error, kv
    // their eps; ff F_eps / 100).
    checkEps_ = oracle_.receiverCheckEps();
    // The receiver check, for oracles that do not judge the aggregate themselves.
    if (!oracle_.needsReceiverError() && oracle_.refinesByError()) {
        if (s_.receiverEps > 0.0)
            guardEps_ = s_.receiverEps;
        else if (s_.receiverEps < 0.0 && !std::isnan(checkEps_))
            guardEps_ = checkEps_;  // auto: the (stage's) oracle maps its eps
    }
    beginChecks();
    // Kernel samples travel with their links (computed once, when the link
    // is made; the initial links get theirs here), one per link that stores
    // them (Hierarchy::storesKernelSamples), in link order.
    if (aggregate_) {
        pendingS_ = h_.hasKernelSamples() ? h_.takeKernelSamples()
                                          : solver_.computeKernelSamples(h_, recv_, pending_);
        finalS_.reserve(pendingS_.size());
    }
}

void RefinementPass::beginChecks() {
    const bool nearStandIns = solver_.linker_ && solver_.linker_->settings().standInNear;
    CheckPass pass{oracle_,          h_,      solver_.links_,
                   solver_.engine_,  recv_,   pending_,
                   solver_.epsPower_, solver_.scene_->emittedPower(),
                   checkEps_,        guardEps_, nearStandIns};
    CheckNeeds needs;
    if (res_.checks.empty())
        for (auto& c : solver_.checks_) res_.checks.push_back({c->name()});
    for (size_t k = 0; k < solver_.checks_.size(); ++k) {
        RefinementCheck* c = solver_.checks_[k].get();
        if (!c->beginPass(pass)) continue;
        checks_.push_back(c);
        checkIndex_.push_back(k);
        ++res_.checks[k].passes;
        needs.receiverErrors |= c->needs().receiverErrors;
        needs.senderTotals |= c->needs().senderTotals;
    }
    amended_ = std::vector<std::atomic<uint64_t>>(checks_.size());
    aggregate_ = oracle_.needsReceiverError() || needs.receiverErrors;
    // The error oracles read the sender totals in their own decision.
    wantTotals_ = (oracle_.needsReceiverError() && s_.senderTotal) || needs.senderTotals;
}

void RefinementPass::computeDeferred() {
    // Deferred links whose sending cluster now carries light are computed
    // before anything judges them (cluster.defer_dark).
    if (!solver_.linker_ || !solver_.linker_->settings().deferDark) return;
    std::atomic<uint64_t> rays{0}, computed{0};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, pending_.size(), 1024), [&](const auto& range) {
        uint64_t localRays = 0, localComputed = 0;
        for (size_t i = range.begin(); i != range.end(); ++i) {
            const uint32_t s = pending_[i].sender;
            if (!(pending_[i].flags & Link::kDeferred) || !(maxComponent(h_.maxB(s)) > 0)) continue;
            uint32_t nr = 0;
            pending_[i] = solver_.links_.make(h_, recv_[i], s, nr);
            localRays += nr;
            ++localComputed;
        }
        rays += localRays;
        computed += localComputed;
    });
    res_.totalRays += rays;
    rec_.formFactors += computed;
    res_.deferredLinksComputed += computed;
}

void RefinementPass::judgeRound(bool capHit) {
    const size_t n = pending_.size();
    CheckRound round{h_, solver_.links_, recv_, pending_, solver_.epsPower_, capHit};
    for (RefinementCheck* c : checks_) c->prepareRound(round);
    if (capHit) return;  // every decision stays Accept: the round is kept as it is
    std::vector<SenderTotal> stot;
    std::vector<ReceiverError> rerr;
    LeafRanges ranges;
    if (aggregate_) leafRanges(h_, ranges);
    if (aggregate_ && wantTotals_)
        senderTotals(h_, recv_, pending_, finalRecv_, finalLinks_, stot, &ranges);
    if (aggregate_)
        receiverErrors(h_, recv_, pending_, pendingS_, finalRecv_, finalLinks_, finalS_, rerr,
                       solver_.coupling_ != nullptr, {}, &ranges);
    // rerr and stot hold the links that carry kernel samples only: each
    // block of links starts at its first such link.
    constexpr size_t kBlock = 1024;
    const size_t blocks = (n + kBlock - 1) / kBlock;
    std::vector<size_t> blockFirst(blocks + 1, 0);
    if (aggregate_) {
        for (size_t i = 0; i < n; ++i)
            if (h_.carriesKernelSamples(recv_[i], pending_[i])) ++blockFirst[i / kBlock + 1];
        for (size_t b = 0; b < blocks; ++b) blockFirst[b + 1] += blockFirst[b];
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks, 1), [&](const auto& range) {
        for (size_t blk = range.begin(); blk != range.end(); ++blk) {
            size_t k = blockFirst[blk];
            for (size_t i = blk * kBlock, iEnd = std::min(n, i + kBlock); i < iEnd; ++i) {
                const bool carries = aggregate_ && h_.carriesKernelSamples(recv_[i], pending_[i]);
                const size_t si = carries ? k++ : 0;
                decision_[i] = uint8_t(decideLink(i, carries, si, round, rerr, stot));
            }
        }
    });
    // What the decisions needed is freed before the next round's links are
    // made (the largest arrays of a round otherwise coexist).
    releaseVector(rerr);
    releaseVector(ranges.lo);
    releaseVector(ranges.hi);
    releaseVector(stot);
    RoundDecisions decisions{decision_, std::vector<uint8_t>(n, 0)};
    std::vector<uint8_t> before;
    for (size_t k = 0; k < checks_.size(); ++k) {
        before = decision_;
        checks_[k]->finishRound(round, decisions);
        uint64_t changed = 0;
        for (size_t i = 0; i < n; ++i) changed += before[i] != decision_[i];
        amended_[k] += changed;
    }
    for (RefinementCheck* c : checks_) c->releaseRound();
}

Decision RefinementPass::decideLink(size_t i, bool carries, size_t si, const CheckRound& round,
                                    const std::vector<ReceiverError>& rerr,
                                    const std::vector<SenderTotal>& stot) const {
    const Link& l = pending_[i];
    const uint32_t r = recv_[i], s = l.sender;
    if (l.flags & Link::kOpen) return solver_.links_.forcedDecision(h_, r, s);
    // A surface link neither of whose ends can subdivide is kept whatever it
    // is judged to be (every refusal goes through oracles::constrain or its
    // like); finely tessellated scenes have most of their links there.
    if (!h_.canSubdivide(r) && !h_.canSubdivide(s) && !(l.flags & Link::kSampled))
        return Decision::Accept;
    // Surface links judged by the receiver aggregate need no per-link
    // form-factor range (17 contour integrals each).
    const bool wantBounds = bounds_ && !(aggregate_ && surfacePair(h_, r, s));
    oracles::LinkEstimate e = solver_.linkEstimate(h_, r, l, wantBounds, oracle_.needsUpperBound());
    if (solver_.coupling_ && oracle_.needsBasisResidual() && surfacePair(h_, r, s) &&
        !(l.flags & Link::kPartial)) {
        // The part of the transfer the receiver's basis truncates
        // (LinkEstimate::basisResidualF). Not for partially visible links:
        // the residual is of the unoccluded kernel and does not see a shadow
        // edge across the receiver, so they keep the constant rule.
        transport::ElementRef er{h_.patch(r), h_.domain(r), h_.stableId(r)};
        transport::ElementRef es{h_.patch(s), h_.domain(s), h_.stableId(s)};
        e.basisResidualF = solver_.coupling_->projectionResidual(er, es) * l.vis();
    }
    if (aggregate_) {
        static const ReceiverError kNotEvaluated{};
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
    for (RefinementCheck* c : checks_) c->weigh(round, i, e);
    Decision d = oracles::constrain(oracle_.decide(e), e);
    for (size_t k = 0; k < checks_.size(); ++k) {
        const Decision before = d;
        checks_[k]->amend(round, i, e, d);
        if (d != before) amended_[k].fetch_add(1, std::memory_order_relaxed);
    }
    return d;
}

std::vector<size_t> RefinementPass::markRound(uint64_t& marked) {
    // Collect the elements to subdivide (subdivided in index order below).
    const size_t n = pending_.size();
    mark_.assign(h_.numElements(), 0);
    std::vector<size_t> offset(n + 1, 0);
    for (size_t i = 0, k = 0; i < n; ++i) {
        const auto d = Decision(decision_[i]);
        size_t c = 0;
        if (d == Decision::Accept) {
            keepPending(i, k);
        } else {
            skipPending(i, k);
            const bool rr = refinesReceiver(d), ss = refinesSender(d);
            const uint32_t r = recv_[i], s = pending_[i].sender;
            if (rr && !h_.isCluster(r)) mark_[r] = 1;
            if (ss && !h_.isCluster(s)) mark_[s] = 1;
            const size_t nr = rr ? (h_.isCluster(r) ? h_.numChildren(r) : 4) : 1;
            const size_t ns = ss ? (h_.isCluster(s) ? h_.numChildren(s) : 4) : 1;
            c = nr * ns;
            ++refined_;
        }
        offset[i + 1] = offset[i] + c;
    }
    marked = 0;
    for (uint8_t m : mark_) marked += m;
    return offset;
}

void RefinementPass::keepRefined() {
    // A stop before the round is made: the links to be refined are kept as
    // they are (the accepted ones are already kept).
    for (size_t i = 0, k = 0; i < pending_.size(); ++i) {
        if (Decision(decision_[i]) == Decision::Accept)
            skipPending(i, k);
        else
            keepPending(i, k);
    }
}

void RefinementPass::subdivide() {
    size_t leaves = 0;
    for (uint32_t e = 0; e < uint32_t(mark_.size()); ++e)
        leaves += (mark_[e] && h_.firstChild(e) == kNone) ? 1 : 0;
    h_.reserveElements(4 * leaves);
    for (uint32_t e = 0; e < uint32_t(mark_.size()); ++e)
        if (mark_[e]) h_.subdivide(e);
}

template <class Fn>
void RefinementPass::forEachChildPair(size_t i, Fn&& fn) const {
    // fn(rc, sc) for each child pair that replaces refined link i, in the
    // order of its slots.
    const auto d = Decision(decision_[i]);
    const uint32_t r = recv_[i], s = pending_[i].sender;
    const bool rr = refinesReceiver(d), ss = refinesSender(d);
    const uint32_t na = rr ? h_.numChildren(r) : 1, nb = ss ? h_.numChildren(s) : 1;
    for (uint32_t a = 0; a < na; ++a)
        for (uint32_t b = 0; b < nb; ++b) fn(rr ? h_.child(r, a) : r, ss ? h_.child(s, b) : s);
}

bool RefinementPass::childSampled(uint32_t rc, uint32_t sc) const {
    // A child pair of two surface elements gets kernel samples when the
    // receiver can subdivide (Hierarchy::storesKernelSamples); a surface
    // self-pair makes no link and none.
    return rc != sc && surfacePair(h_, rc, sc) && h_.canSubdivide(rc);
}

void RefinementPass::linkChildren(const std::vector<size_t>& offset) {
    // Links between the children, with their transfers (parallel; each slot
    // is written by exactly one task).
    const size_t n = pending_.size(), newCount = offset[n];
    nrecv_.assign(newCount, 0);
    nlinks_.assign(newCount, Link{});
    // Where each refined link's children put their samples.
    std::vector<size_t> sampleOffset(aggregate_ ? n + 1 : 0, 0);
    if (aggregate_) {
        for (size_t i = 0; i < n; ++i) {
            size_t c = 0;
            if (offset[i + 1] > offset[i])
                forEachChildPair(i, [&](uint32_t rc, uint32_t sc) { c += childSampled(rc, sc); });
            sampleOffset[i + 1] = sampleOffset[i] + c;
        }
    }
    nS_.assign(aggregate_ ? sampleOffset[n] : 0, KernelSamples{});
    std::atomic<uint64_t> rays{0};
    // Each round of a large first refinement can take minutes: its own
    // progress bar (drawn only past a second) with the time left.
    ++round_;
    ProgressBar bar(fmt::format("iter {} round {}: {} links", rec_.iteration, round_, newCount), n,
                    solver_.progress_);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const auto& range) {
        uint64_t localRays = 0;
        for (size_t i = range.begin(); i != range.end(); ++i) {
            if (offset[i + 1] == offset[i]) continue;
            size_t o = offset[i];
            size_t so = aggregate_ ? sampleOffset[i] : 0;
            forEachChildPair(i, [&](uint32_t rc, uint32_t sc) {
                uint32_t nr = 0;
                // A self-link between surfaces carries nothing (planar
                // patches); between clusters it is kept, to be opened.
                nlinks_[o] = rc == sc && !h_.isCluster(rc) ? Link{}
                                                           : solver_.links_.make(h_, rc, sc, nr);
                nrecv_[o] = rc;
                if (aggregate_ && childSampled(rc, sc)) {
                    // Samples only for links that carry light (the others are
                    // dropped, or kept for the oracle with zero samples).
                    if (nlinks_[o].K > 0) nS_[so] = solver_.linkSamples(h_, rc, sc);
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
    rec_.rays += rays;
    rec_.formFactors += newCount;
}

void RefinementPass::dropEmpty() {
    // Drop links that carry nothing (back-facing or fully occluded pairs).
    // Links to be opened (kOpen), cluster links whose judged rays were all
    // (kUncertain) or partly (kPartial) blocked, and deferred links
    // (kDeferred, computed later) are kept whatever their K carries: the
    // oracle still judges them.
    size_t w = 0, ws = 0, rs = 0;
    for (size_t i = 0; i < nlinks_.size(); ++i) {
        const bool clusterLink = h_.isCluster(nrecv_[i]) ||
                                 (nlinks_[i].sender != kNone && h_.isCluster(nlinks_[i].sender));
        const bool keep = clusterLink ? (nlinks_[i].flags & (Link::kOpen | Link::kUncertain |
                                                             Link::kPartial | Link::kDeferred)) != 0
                                      : solver_.links_.keepSurfaceLink(nlinks_[i]);
        const bool sampled = aggregate_ && h_.storesKernelSamples(nrecv_[i], nlinks_[i]);
        const size_t si = sampled ? rs++ : 0;
        if (!(nlinks_[i].K > 0) && !keep) continue;
        nlinks_[w] = nlinks_[i];
        nrecv_[w] = nrecv_[i];
        if (sampled) nS_[ws++] = nS_[si];
        ++w;
    }
    HRAD_CHECK(rs == nS_.size());
    nlinks_.resize(w);
    nrecv_.resize(w);
    if (aggregate_) nS_.resize(ws);
    pending_ = std::move(nlinks_);
    recv_ = std::move(nrecv_);
    pendingS_ = std::move(nS_);
    nlinks_.clear();
    nrecv_.clear();
    nS_.clear();
}

void RefinementPass::finish() {
    for (size_t k = 0; k < checks_.size(); ++k) res_.checks[checkIndex_[k]].amended += amended_[k];
    // Refinement stopped early: the links it was about to open get a
    // stand-in transfer instead of none (cluster/link.h "Stand-ins").
    if (res_.linkCapHit || res_.memoryBudgetHit || res_.stoppedEarly())
        solver_.standInUnopened(h_, finalRecv_, finalLinks_, res_, rec_);
    if (aggregate_)
        h_.setLinks(finalRecv_, std::move(finalLinks_), std::move(finalS_));
    else
        h_.setLinks(finalRecv_, std::move(finalLinks_));
}

void RefinementPass::keepPending(size_t i, size_t& k) {
    finalRecv_.push_back(recv_[i]);
    finalLinks_.push_back(pending_[i]);
    if (aggregate_ && h_.storesKernelSamples(recv_[i], pending_[i]))
        finalS_.push_back(pendingS_[k++]);
}

void RefinementPass::skipPending(size_t i, size_t& k) const {
    if (aggregate_ && h_.storesKernelSamples(recv_[i], pending_[i])) ++k;
}

}  // namespace hrad::hr
