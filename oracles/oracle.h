// Refinement oracles: the pluggable decision "is this link good enough?".
//
// The hierarchical solver (hr/) builds a LinkEstimate for every link and asks
// an Oracle for a Decision (RenderPark's InteractionEvaluationCode). The oracle
// never sees the hierarchy: everything it may use is in the LinkEstimate, so
// new oracles are written and tested in isolation.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/types.h"

namespace hrad::oracles {

enum class Decision : uint8_t { Accept = 0, RefineReceiver = 1, RefineSender = 2, RefineBoth = 3 };

const char* decisionName(Decision d);

/// Everything an oracle may know about one link (receiver r gathers from sender s).
struct LinkEstimate {
    double F = 0.0;            ///< form factor F_rs estimate, visibility included
    double unoccludedF = 0.0;  ///< F_rs without visibility
    double Fupper = 1.0;       ///< conservative upper bound on the unoccluded F_rs
    double visibility = 1.0;   ///< fraction of visibility samples unblocked
    bool partialVisibility = false;
    double receiverArea = 0.0, senderArea = 0.0;
    RGB senderB{0.0};          ///< current radiosity of the sender
    RGB receiverRho{0.0};      ///< reflectance of the receiver
    double importance = 1.0;   ///< receiver importance (Smits, Arvo & Salesin 1992); 1 when unused
    double emittedPower = 1.0; ///< max-channel total emitted power of the scene (normaliser)
    int receiverLevel = 0, senderLevel = 0;
    bool receiverCanSubdivide = false, senderCanSubdivide = false;
    bool receiverIsCluster = false, senderIsCluster = false;

    /// F_sr by reciprocity: A_r F_rs / A_s.
    double reverseF() const { return senderArea > 0 ? F * receiverArea / senderArea : 0.0; }
};

class Oracle {
  public:
    virtual ~Oracle() = default;
    virtual Decision decide(const LinkEstimate& e) const = 0;
    virtual std::string name() const = 0;
    /// One line with every setting, written next to each result.
    virtual std::string describe() const = 0;
};

/// Makes a decision consistent with what each side may do: a refinement of a
/// side that cannot subdivide falls back to the other side, or to Accept.
Decision constrain(Decision d, const LinkEstimate& e);

/// HSA91's choice of side: subdivide the element that looks larger from the
/// other one, i.e. the sender when F_rs > F_sr (Hanrahan, Salzman & Aupperle
/// 1991, Fig. 3 "Refine"), constrained by what may subdivide.
Decision refineLarger(const LinkEstimate& e);

}  // namespace hrad::oracles
