// The limits that stop refinement early, behind one object: the link cap
// (hr.max_links, and the hierarchy's own 32-bit limit), the memory budget
// (memory.budget_mb) and the clock (hr.max_seconds). Past any of them the
// links still to be refined are kept as they are (a coarser solution,
// flagged in the result: link_cap_hit, memory_budget_hit, time_limit_hit);
// the solver then finishes iterating on that hierarchy.
//
// Memory is estimated before a round's links are allocated: what the
// process held apart from links and elements when the pass began (resident
// set), plus the elements, plus the larger of the round itself and the next
// judging pass over the links kept and made (passPeakBytes), within 31/32
// of the budget (the rest for what the estimate leaves out: the
// allocator's overhead, per-thread buffers; bench/results/large_scenes.md).
#pragma once

#include <cstdint>

#include "core/cancel.h"
#include "core/interrupt.h"
#include "core/stop.h"
#include "core/timer.h"
#include "hr/hierarchy.h"
#include "hr/settings.h"

namespace hrad::hr {

struct HrResult;

/// The sizes of one round of a pass, for the memory estimate.
struct RoundSize {
    uint64_t kept = 0;        ///< links kept so far in the pass
    uint64_t pending = 0;     ///< links judged in the round
    uint64_t made = 0;        ///< links the round makes
    uint64_t samples = 0;     ///< kernel-sample blocks held (kept and pending)
    uint64_t keptSamples = 0; ///< of which kept
    uint64_t marked = 0;      ///< elements marked for subdivision
};

class RefinementBudget {
  public:
    /// `couplingBytes`: the bytes a link's coupling matrix adds (polynomial
    /// bases; 0 for the constant basis).
    RefinementBudget(const HrSettings& s, const Timer& solveTimer, uint64_t couplingBytes)
        : s_(s), timer_(solveTimer), couplingBytes_(couplingBytes) {}

    /// Stops on request: outOfTime() then throws Cancelled. nullptr: never.
    void setCancelToken(const CancelToken* token) { cancel_ = token; }
    /// The token and the signal flag alone, without the clock (core/stop.h).
    StopPoll stopPoll() const { return StopPoll{cancel_}; }

    /// Past hr.max_seconds, or asked to stop by SIGINT/SIGTERM (core/interrupt.h,
    /// the command line: stop at this safe point and keep the result); throws
    /// Cancelled when the token was requested (core/cancel.h, the Python module:
    /// nothing half-done is returned).
    bool outOfTime() const {
        if (cancel_) cancel_->throwIfRequested();
        return interruptSignal() != 0 || (s_.maxSeconds > 0 && timer_.seconds() > s_.maxSeconds);
    }
    /// hr.max_seconds or a signal before a round: true (warned once, flagged
    /// timeLimitHit or interrupted) when past it.
    bool stopForTime(HrResult& res) const;
    /// hr.max_links: true (warned once, flagged) when judging a round of
    /// `pending` links besides `kept` would pass the cap; the round is then
    /// kept unjudged.
    bool linkCapHit(uint64_t kept, uint64_t pending, HrResult& res) const;
    /// Before a round's links are made: false (warned once, flagged) when the
    /// hierarchy's limit or memory.budget_mb would be passed. `fixedBytes`
    /// is what the process held besides links and elements.
    bool roundFits(const Hierarchy& h, const RoundSize& round, uint64_t fixedBytes,
                   HrResult& res) const;
    /// What a judging pass over `links` links (`samples` of them with
    /// kernel samples) and `elements` elements allocates at its peak,
    /// besides the elements themselves.
    uint64_t passPeakBytes(uint64_t links, uint64_t samples, uint64_t elements) const;

  private:
    const HrSettings& s_;
    const Timer& timer_;
    uint64_t couplingBytes_;
    const CancelToken* cancel_ = nullptr;
};

}  // namespace hrad::hr
