#include "oracles/oracle.h"

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

ErrorNorm readErrorNorm(const Params& p, const std::string& key, ErrorNorm def) {
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

}  // namespace hrad::oracles
