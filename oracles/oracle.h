// Refinement oracles: the pluggable decision "is this link good enough?".
//
// The hierarchical solver (hr/) builds a LinkEstimate for every link and asks
// an Oracle for a Decision (RenderPark's InteractionEvaluationCode). The oracle
// never sees the hierarchy: everything it may use is in the LinkEstimate, so
// new oracles are written and tested in isolation.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
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
    double emittedPower = 1.0; ///< the power eps is a fraction of (normaliser; hr.eps_power, hr/solver.h: by default the smaller of the scene's emitted power and its predicted reflected power, max channel)
    /// Max-channel largest emitted radiosity E of any patch (normaliser of
    /// radiosity-norm error oracles, like RenderPark's max self-emitted radiance).
    double emittedRadiosity = 1.0;
    /// Range of the point-to-element form factor F_{dA(x) -> s} over receiver
    /// points x, visibility included: Fmin <= F <= Fmax. The solver fills them
    /// only for oracles whose needsBounds() is true (transport/formfactor.h
    /// pointRange; a partially visible link has Fmin = 0; a link touching a
    /// cluster has [0, max(F, Fupper)]). The defaults are the trivial interval.
    double Fmin = 0.0, Fmax = 1.0;
    /// Polynomial bases (hr.basis above constant), surface links, for oracles
    /// whose needsBasisResidual() is true: max over check points of the
    /// receiver of |P(x) - F(x)| times the visibility fraction, where F(x) is
    /// the point form factor to the sender and P its projection onto the
    /// receiver's basis (transport CouplingEngine::projectionResidual): the
    /// part of the transfer the basis truncates. -1 when not computed (also
    /// for partially visible links: hr/solver.cpp).
    double basisResidualF = -1.0;
    /// Receiver-aggregate kernel error (hr/receiver_error.h), filled only for
    /// oracles whose needsReceiverError() is true and only for links between
    /// two surface elements (negative otherwise: not evaluated). With x_k the
    /// receiver's sample points (corners, edge midpoints, centroid) and
    ///   D(x_k) = sum over the receiver's surface links l of
    ///            rho_r B_l v_l (F_l(x_k) - F_l)
    /// (F_l(x) the point-to-sender form factor, F_l its receiver average,
    /// v_l the link's visibility fraction), D is the error that giving
    /// every point of the receiver the average makes, all links together:
    /// links whose kernels vary in opposite directions cancel (in a closed
    /// room the point form factors to all senders sum to one everywhere).
    /// Partially visible links add rho_r B_l F_l unsigned (where the shadow
    /// falls is unknown). Radiosity units, max channel.
    double receiverRange = -1.0;      ///< max_k D(x_k) - min_k D(x_k)
    double receiverDeviation = -1.0;  ///< max_k |D(x_k)|
    /// This link's own part: max_k |rho_r B_s v (F(x_k) - F)| (+ the unsigned
    /// partial-visibility term).
    double linkDeviation = 0.0;
    uint32_t receiverLinks = 0;       ///< surface links the aggregate sums
    /// Largest rho_r |B_c - B_s| (max channel) over the children c of a
    /// subdivided surface sender, 0 for a leaf or a cluster: F times it is
    /// the error of gathering the sender's average instead of its parts
    /// (the sender side of Lischinski, Smits & Greenberg 1994).
    double senderSpread = 0.0;
    /// Sender side of the receiver aggregate (hr/receiver_error.h): the sum
    /// over the receiver's surface links of K_l rho_r max_c |B_c - B_l|, and
    /// this link's own term; negative when not evaluated. The error of
    /// gathering averaged senders, which accumulates with one sign.
    double senderAggregate = -1.0, linkSenderPart = 0.0;
    /// Sender side summed per sender over all its receivers (power, max
    /// channel; hr/receiver_error.h SenderTotal, hr.sender_total): negative
    /// when not evaluated; this link's term; the sender's counted links.
    double senderTotal = -1.0, linkSenderTotal = 0.0;
    uint32_t senderLinks = 0;
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
    /// True when decide() reads LinkEstimate::Fmin / Fmax. Filling them costs
    /// extra point-to-element form factors for every link judged, so the
    /// solver only does it when asked.
    virtual bool needsBounds() const { return false; }
    /// True when decide() reads LinkEstimate::Fupper. For surface links
    /// judged by an independent visibility (hr.judge_visibility) the bound
    /// is not stored in the link and costs a geometric bound per link judged.
    virtual bool needsUpperBound() const { return false; }
    /// True when decide() reads LinkEstimate::basisResidualF (filled only
    /// when the solve uses a basis above constant).
    virtual bool needsBasisResidual() const { return false; }
    /// True when decide() reads the receiver aggregate (receiverRange,
    /// receiverDeviation, linkDeviation, receiverLinks); it costs point form
    /// factors at 7-9 receiver points for every surface link of every
    /// receiver judged.
    virtual bool needsReceiverError() const { return false; }
    virtual std::string name() const = 0;
    /// False for an oracle that refines to a fixed mesh whatever the error
    /// (uniform): it has no eps, so there are no eps stages, and none of the
    /// checks the solver adds to the decisions (hr/checks/) applies.
    virtual bool refinesByError() const { return true; }
    /// The fraction of the power hr.eps_power names (LinkEstimate::
    /// emittedPower) this oracle's eps is, where eps is a power threshold; NaN for an oracle whose eps is something else (ff:
    /// a form factor) or that has none (uniform).
    virtual double powerEps() const { return std::numeric_limits<double>::quiet_NaN(); }
    /// The value of its `eps` setting as it decides (its default when unset);
    /// NaN for an oracle without one (refinesByError() false).
    virtual double eps() const { return std::numeric_limits<double>::quiet_NaN(); }
    /// The fraction of that power the checks the solver adds to every
    /// oracle's decision use: the receiver check under hr.receiver_eps = auto,
    /// the power a sampled near link or a partially visible cluster link may
    /// misplace, the leaf budget (hr/solver.h). powerEps() where eps is a
    /// power fraction; an oracle with another eps maps it (ff: F_eps / 100);
    /// NaN: no checks.
    virtual double receiverCheckEps() const { return powerEps(); }
    /// One line with every setting, written next to each result.
    virtual std::string describe() const = 0;
};

/// How the error oracles (`error`, `kv`) compare the radiosity error dB a link
/// may make at its receiver with eps:
///   Power      A_r dB <= eps * emittedPower: the error in power, relative to
///              the power hr.eps_power names (LinkEstimate::emittedPower), in
///              the units of `bfa`;
///   Radiosity  dB <= eps * emittedRadiosity: the error in radiosity, relative
///              to the brightest emitter (Lischinski et al. 1993; RenderPark's
///              RADIANCE_ERROR norm). Does not shrink with the element, so
///              refinement near shared edges runs to the minimum area.
enum class ErrorNorm : uint8_t { Power = 0, Radiosity = 1 };

/// Reads `key` ("power" | "radiosity") from p.
ErrorNorm readErrorNorm(const Params& p, const Params::Key& key, ErrorNorm def);
const char* errorNormName(ErrorNorm n);
/// True when the receiver radiosity error dB is within eps in the given norm.
bool errorWithinEps(double dB, double eps, ErrorNorm norm, const LinkEstimate& e);

/// The shared part of the oracles that judge a link by the radiosity error it
/// makes at its receiver, estimated from the receiver's point form-factor
/// range (`error`, `kv`): settings, decision and description. Subclasses give
/// the name and the estimate dB.
///   eps       double  1e-3     threshold (0, 1], relative as set by norm
///   norm      string  "power"  "power" | "radiosity" (ErrorNorm)
///   min_area  double  0        elements at or below this area are not subdivided
///   side      string  "larger" which element a refused link subdivides:
///                              "larger" (refineLarger, HSA91) or "receiver"
class VariationOracle : public Oracle {
  public:
    struct Settings {
        double eps = 1e-3;
        ErrorNorm norm = ErrorNorm::Power;
        double minArea = 0.0;
        bool refineReceiver = false;  ///< side = "receiver"
        static Settings fromParams(const Params& p);
    };
    explicit VariationOracle(Settings s) : s_(s) {}
    /// Accept when linkError is within eps, else subdivide the side chosen by
    /// `side`, constrained by what may subdivide (and min_area).
    Decision decide(const LinkEstimate& e) const final;
    bool needsBounds() const final { return true; }
    bool needsReceiverError() const final { return true; }
    double powerEps() const final { return s_.eps; }
    double eps() const final { return s_.eps; }
    std::string describe() const final;
    /// The radiosity error dB of the link at its receiver (max channel, with
    /// importance), from the link's own form-factor range: used for links
    /// that touch a cluster, which have no receiver aggregate.
    virtual double linkError(const LinkEstimate& e) const = 0;
    /// The error of the receiver's irradiance from all its surface links
    /// (LinkEstimate::receiverRange or receiverDeviation).
    virtual double receiverError(const LinkEstimate& e) const = 0;

  protected:
    Settings s_;
};

/// Whether the link carries at least an even share of its receiver's
/// aggregate error (its deviation times the receiver's link count reaches
/// the receiver's): the links refined when the aggregate is over eps.
inline bool carriesReceiverShare(const LinkEstimate& e) {
    return e.linkDeviation * std::max<uint32_t>(1, e.receiverLinks) >= e.receiverDeviation;
}

/// The refinement for a receiver aggregate over eps: RefineReceiver, or
/// Accept when the receiver cannot subdivide. Not the sender instead (as
/// constrain() would): the children of a sender sum to its kernel, so
/// refining it leaves the receiver's aggregate where it was, and a receiver
/// at the smallest area would have every sender it sees refined to the
/// smallest area too, for nothing.
inline Decision receiverRefinement(const LinkEstimate& e) {
    return e.receiverCanSubdivide ? Decision::RefineReceiver : Decision::Accept;
}

/// The same for a sender-side aggregate over eps (the spread of an averaged
/// sender's radiosity): RefineSender, or Accept when the sender cannot
/// subdivide. Refining the receiver instead would split the same error
/// among its children, each then under eps, without lowering it.
inline Decision senderRefinement(const LinkEstimate& e) {
    return e.senderCanSubdivide ? Decision::RefineSender : Decision::Accept;
}

/// Whether the sender-side error summed over all the sender's receivers
/// (LinkEstimate::senderTotal, when given) exceeds eps of the power
/// hr.eps_power names and the link carries at least an even share of it:
/// the link is then refined on the sender side.
inline bool senderTotalRefines(const LinkEstimate& e, double eps) {
    return e.senderTotal >= 0.0 && e.senderTotal * e.importance > eps * e.emittedPower &&
           e.linkSenderTotal * std::max<uint32_t>(1, e.senderLinks) >= e.senderTotal;
}

/// Makes a decision consistent with what each side may do: a refinement of a
/// side that cannot subdivide falls back to the other side, or to Accept.
Decision constrain(Decision d, const LinkEstimate& e);

/// HSA91's choice of side: subdivide the element that looks larger from the
/// other one, i.e. the sender when F_rs > F_sr (Hanrahan, Salzman & Aupperle
/// 1991, Fig. 3 "Refine"), constrained by what may subdivide.
Decision refineLarger(const LinkEstimate& e);

}  // namespace hrad::oracles
