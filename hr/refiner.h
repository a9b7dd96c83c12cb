// One judging pass of hierarchical refinement (Hanrahan, Salzman & Aupperle
// 1991, "Refine", unrolled by level): every link is judged by the oracle and
// amended by the enabled refinement checks (hr/checks/); the elements to
// subdivide are marked and subdivided serially in index order; the refined
// links are replaced by links between the children, whose transfers are
// computed in parallel; the new links are judged in the next round, until a
// round refines nothing. Results are independent of thread scheduling.
//
// Phases, one function each: computeDeferred (links from dark clusters that
// now carry light, cluster.defer_dark), judgeRound (aggregates, oracle,
// checks), markRound, the budget (hr/budget.h: links, memory, clock),
// subdivide, linkChildren, dropEmpty; finish hands the kept links back to
// the hierarchy (stand-ins for links a stopped pass left unopened).
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "hr/solver.h"

namespace hrad::hr {

class RefinementPass {
  public:
    /// `fixedBytes`: what the process held besides links and elements when
    /// the pass began (memory.budget_mb).
    RefinementPass(HrSolver& solver, Hierarchy& h, const oracles::Oracle& oracle, HrResult& res,
                   IterationRecord& rec, uint64_t fixedBytes);
    /// Runs the pass; returns the links refined.
    uint64_t run();

  private:
    void begin();
    void beginChecks();
    void computeDeferred();
    /// The aggregates the oracle and the checks read, then every link's
    /// decision (decision_).
    void judgeRound(bool capHit);
    oracles::Decision decideLink(size_t i, bool carries, size_t si, const CheckRound& round,
                                 const std::vector<ReceiverError>& rerr,
                                 const std::vector<SenderTotal>& stot) const;
    /// Keeps the accepted links, marks the elements to subdivide and returns
    /// the children links' offsets per pending link.
    std::vector<size_t> markRound(uint64_t& marked);
    void keepRefined();
    void subdivide();
    void linkChildren(const std::vector<size_t>& offset);
    void dropEmpty();
    void finish();
    /// Moves pending link i (visited in increasing order from 0, with
    /// cursor k over pendingS_) to the kept links; skipPending advances k.
    void keepPending(size_t i, size_t& k);
    void skipPending(size_t i, size_t& k) const;
    template <class Fn>
    void forEachChildPair(size_t i, Fn&& fn) const;
    bool childSampled(uint32_t rc, uint32_t sc) const;

    HrSolver& solver_;
    Hierarchy& h_;
    const oracles::Oracle& oracle_;
    HrResult& res_;
    IterationRecord& rec_;
    const HrSettings& s_;
    uint64_t fixedBytes_ = 0;
    std::vector<uint32_t> recv_, finalRecv_, nrecv_;
    std::vector<Link> pending_, finalLinks_, nlinks_;
    std::vector<KernelSamples> pendingS_, finalS_, nS_;
    std::vector<uint8_t> decision_, mark_;
    /// The checks taking part in this pass, in registry order, with their
    /// index in the solve's (HrResult::checks) and the decisions each changed.
    std::vector<RefinementCheck*> checks_;
    std::vector<size_t> checkIndex_;
    mutable std::vector<std::atomic<uint64_t>> amended_;
    bool aggregate_ = false;   ///< receiver errors are computed (oracle or a check)
    bool wantTotals_ = false;  ///< sender totals are computed
    bool bounds_ = false;
    double checkEps_ = 0.0, guardEps_ = 0.0;
    uint64_t refined_ = 0;
    int round_ = 0;
};

}  // namespace hrad::hr
