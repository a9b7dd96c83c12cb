#include <algorithm>
#include "oracles/oracle.h"

#include <fmt/format.h>

namespace hrad::oracles {

const char* decisionName(Decision d) {
    switch (d) {
        case Decision::Accept: return "accept";
        case Decision::RefineReceiver: return "refine-receiver";
        case Decision::RefineSender: return "refine-sender";
        case Decision::RefineBoth: return "refine-both";
    }
    return "?";
}

ErrorNorm readErrorNorm(const Params& p, const Params::Key& key, ErrorNorm def) {
    std::string v = p.getEnum(key, errorNormName(def), {"power", "radiosity"});
    return v == "radiosity" ? ErrorNorm::Radiosity : ErrorNorm::Power;
}

const char* errorNormName(ErrorNorm n) {
    return n == ErrorNorm::Radiosity ? "radiosity" : "power";
}

bool errorWithinEps(double dB, double eps, ErrorNorm norm, const LinkEstimate& e) {
    if (norm == ErrorNorm::Radiosity) return dB <= eps * e.emittedRadiosity;
    return dB * e.receiverArea <= eps * e.emittedPower;
}

Decision constrain(Decision d, const LinkEstimate& e) {
    bool r = e.receiverCanSubdivide, s = e.senderCanSubdivide;
    switch (d) {
        case Decision::Accept: return d;
        case Decision::RefineReceiver:
            return r ? d : (s ? Decision::RefineSender : Decision::Accept);
        case Decision::RefineSender:
            return s ? d : (r ? Decision::RefineReceiver : Decision::Accept);
        case Decision::RefineBoth:
            if (r && s) return d;
            if (r) return Decision::RefineReceiver;
            if (s) return Decision::RefineSender;
            return Decision::Accept;
    }
    return Decision::Accept;
}

Decision refineLarger(const LinkEstimate& e) {
    // F_rs large: the sender subtends a large solid angle from the receiver.
    // By reciprocity F_rs / F_sr = A_s / A_r, so this subdivides the larger
    // element; ties go to the sender. (Refining both sides of comparable
    // elements was tried: 2-3x the links for a small gain in the furnace.)
    Decision d = e.F >= e.reverseF() ? Decision::RefineSender : Decision::RefineReceiver;
    return constrain(d, e);
}

VariationOracle::Settings VariationOracle::Settings::fromParams(const Params& p) {
    Settings s;
    s.eps = p.getDouble({"eps",
                         "error oracles: power a receiver's irradiance may misplace, as a fraction "
                         "of the emitted power"},
                        s.eps, 0.0, 1.0, true);
    s.norm = readErrorNorm(
        p, {"norm", "what the error is measured in: power (W, the default) or radiosity"}, s.norm);
    s.minArea = p.getDouble({"min_area", "elements below this area are not refined by the oracle"},
                            s.minArea, 0.0, 1e300);
    s.refineReceiver =
        p.getEnum(
            {"side", "links touching a cluster: a refused link subdivides the element that looks "
                     "larger from the other (HSA91), or the receiver (which never resolves the "
                     "sender's own variation)"},
            "larger", {"larger", "receiver"}) == "receiver";
    return s;
}

Decision VariationOracle::decide(const LinkEstimate& e) const {
    LinkEstimate c = e;
    c.receiverCanSubdivide = e.receiverCanSubdivide && e.receiverArea > s_.minArea;
    c.senderCanSubdivide = e.senderCanSubdivide && e.senderArea > s_.minArea;
    if (e.receiverRange >= 0.0) {
        // A surface link is judged by its receiver's aggregate error: the
        // receiver's links are accepted together when it is within eps.
        // Otherwise the links that carry at least an even share of it are
        // refined on the receiver side (at least one link always is), the
        // others wait for the next round, which evaluates the aggregate
        // again. Refining the sender would not change the receiver's
        // irradiance (the children's coefficients sum to the parent's), so
        // the sender is refined only for its own error: the spread of its
        // children's radiosities; and a receiver that cannot subdivide
        // accepts what it has (receiverRefinement).
        double err = receiverError(e) * e.importance;
        // The share compares deviations with deviations (the range of one
        // link's error can exceed its largest deviation from the mean).
        bool receiverBad = !errorWithinEps(err, s_.eps, s_.norm, e) && carriesReceiverShare(e) &&
                           c.receiverCanSubdivide;
        // The sender side is judged by its own aggregate when the solver
        // gives one: the receiver's averaged senders together within eps,
        // the links with at least an even share of it refined on the sender.
        bool senderBad =
            e.senderAggregate >= 0.0
                ? !errorWithinEps(e.senderAggregate * e.importance, s_.eps, s_.norm, e) &&
                      e.linkSenderPart > 0.0 &&
                      e.linkSenderPart * std::max<uint32_t>(1, e.receiverLinks) >= e.senderAggregate
                : !errorWithinEps(e.F * e.senderSpread * e.importance, s_.eps, s_.norm, e);
        // The same error summed over every receiver of the sender (when the
        // solver gives it, hr.sender_total): in power, against eps times
        // the emitted power, the links with at least an even share refined.
        if (!senderBad && s_.norm == ErrorNorm::Power && senderTotalRefines(e, s_.eps))
            senderBad = true;
        // Each side is refined for its own error only (receiverRefinement,
        // senderRefinement): a side that cannot subdivide accepts it.
        senderBad = senderBad && c.senderCanSubdivide;
        if (!receiverBad && !senderBad) return Decision::Accept;
        return receiverBad && senderBad ? Decision::RefineBoth
               : receiverBad            ? Decision::RefineReceiver
                                        : Decision::RefineSender;
    }
    if (errorWithinEps(linkError(e), s_.eps, s_.norm, e)) return Decision::Accept;
    if (s_.refineReceiver) return constrain(Decision::RefineReceiver, c);
    return refineLarger(c);
}

std::string VariationOracle::describe() const {
    return fmt::format("{}(eps={}, norm={}, min_area={}, side={})", name(), s_.eps,
                       errorNormName(s_.norm), s_.minArea, s_.refineReceiver ? "receiver" : "larger");
}

}  // namespace hrad::oracles
