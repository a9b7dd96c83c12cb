// Refinement checks: the amendments the solver makes to an oracle's
// decisions, one family with one interface.
//
// A judging pass asks the oracle for a decision on every link
// (oracles/oracle.h), then runs the enabled checks in the order of the
// registry (hr/checks/registry.cpp) on it. A check may only turn an
// accepted link into a refined one, or choose the side a refusal
// subdivides; it never coarsens. The receiver check and the sender total
// hold the error of a receiver's (a sender's) links taken together within
// eps (after the error-driven refinement of Lischinski et al. 1994 and
// Holzschuch & Sillion 1998, hr/receiver_error.h), the leaf budget the sum
// of the leaves' errors, and the cluster checks the light a cluster link
// may carry wrongly (Smits, Arvo & Greenberg 1994 judge cluster links by
// bounds; here by the link's own uncertainty and unseen fraction).
//
// Life cycle. Checks live for the whole solve (HrSolver owns them).
// beginPass() decides, from the pass's oracle and the settings, whether the
// check takes part in the pass and what data it needs computed; each round
// of the pass (the links of one level of refinement) then calls
// prepareRound() serially, amend() in parallel for every link the oracle
// judged (thread-safe: it may write only state of link i), and
// finishRound() serially once all decisions of the round are known (sums
// over the round). atConvergence() lets a check ask for one more judging
// pass where the solve would stop (the balanced leaf budget).
//
// A new check is one file with its class and factory and one row in
// hr/checks/registry.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "hr/hierarchy.h"
#include "hr/link_builder.h"
#include "hr/receiver_error.h"
#include "hr/settings.h"
#include "oracles/oracle.h"

namespace hrad::hr {

/// What a judging pass is: its oracle and the powers eps refers to.
struct CheckPass {
    const oracles::Oracle& oracle;
    const Hierarchy& h;
    const LinkBuilder& links;
    const transport::FormFactorEngine& engine;
    const std::vector<uint32_t>& recv;  ///< the receivers of the pass's first links
    const std::vector<Link>& pending;   ///< the pass's first links
    /// The power eps is a fraction of in this pass (hr.eps_power), max channel.
    double epsPower = 1.0;
    /// The scene's emitted power per channel.
    RGB emitted{0.0};
    /// Oracle::receiverCheckEps(): the oracle's eps as a fraction of that power.
    double checkEps = 0.0;
    /// The receiver check's eps for oracles that do not judge the receiver
    /// aggregate themselves (0: no receiver check in this pass).
    double guardEps = 0.0;
    /// Whether cluster.near = stand_in (the near pairs' stand-ins).
    bool nearStandIns = false;
};

/// One round of a pass: the links judged together.
struct CheckRound {
    const Hierarchy& h;
    const LinkBuilder& links;
    const std::vector<uint32_t>& recv;
    const std::vector<Link>& pending;
    double epsPower = 1.0;
    /// A cap (hr.max_links) holds this round: nothing is judged or refined.
    bool capHit = false;
};

/// The decisions of a round, with the links a finishing check changed.
struct RoundDecisions {
    std::vector<uint8_t>& decision;  ///< oracles::Decision per pending link
    /// 1 where a finishRound() changed the decision (later checks may act on it).
    std::vector<uint8_t> changedInFinish;
    void set(size_t i, oracles::Decision d) {
        decision[i] = uint8_t(d);
        changedInFinish[i] = 1;
    }
    oracles::Decision operator[](size_t i) const { return oracles::Decision(decision[i]); }
};

/// What the checks of a pass need computed for its links.
struct CheckNeeds {
    bool receiverErrors = false;  ///< ReceiverError per surface link (hr/receiver_error.h)
    bool senderTotals = false;    ///< SenderTotal per surface link
};

/// The leaves' error totals of the last convergence check, which the
/// solve's final estimate reuses while the hierarchy is the one checked.
struct LeafTotalsCache {
    LeafErrorTotals totals;
    bool valid = false;  ///< reset by the solver at the start of every iteration
    double seconds = 0.0;
};

/// What the solve hands a check where it would converge.
struct CheckConvergence {
    const Hierarchy& h;
    const oracles::Oracle& oracle;
    const transport::FormFactorEngine& engine;
    double epsPower = 1.0;
    RGB emitted{0.0};
    LeafTotalsCache& cache;
    /// Seconds the check spent, which the solver counts as refinement's.
    double seconds = 0.0;
};

class RefinementCheck {
  public:
    virtual ~RefinementCheck() = default;
    virtual const char* name() const = 0;
    /// Whether the check takes part in this pass; it keeps what it needs of `pass`.
    virtual bool beginPass(const CheckPass& pass) = 0;
    /// What the check reads from the links' estimates in this pass.
    virtual CheckNeeds needs() const { return {}; }
    virtual void prepareRound(const CheckRound&) {}
    /// Before the oracle judges link i: may set the weights of its estimate
    /// (LinkEstimate::importance; the importance check). Called in parallel,
    /// in table order; the oracle and every check's amend() read the result.
    virtual void weigh(const CheckRound&, size_t, oracles::LinkEstimate&) const {}
    /// Amends the decision d on link i of the round, judged with estimate e.
    /// Called in parallel: writes nothing but state of link i.
    virtual void amend(const CheckRound& round, size_t i, const oracles::LinkEstimate& e,
                       oracles::Decision& d) const = 0;
    /// After every link of the round is decided.
    virtual void finishRound(const CheckRound&, RoundDecisions&) {}
    /// Frees what the round held before the next round's links are made.
    virtual void releaseRound() {}
    /// A new eps stage begins.
    virtual void beginStage() {}
    /// Where a stage would converge (and right after a pass it asked for
    /// that refined something): true asks for one more judging pass, in
    /// which the check refines.
    virtual bool atConvergence(CheckConvergence&) { return false; }
    /// True while the check holds refinements for the next pass.
    virtual bool wantsPass() const { return false; }
    /// True when the check must judge every iteration (no lazy refinement).
    virtual bool judgesEveryIteration() const { return false; }
};

}  // namespace hrad::hr
