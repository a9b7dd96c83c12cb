// Importance check (hr.importance = camera | regions): weights every link's
// error by its receiver's importance before the oracle and the other checks
// judge it (LinkEstimate::importance; Smits, Arvo & Salesin 1992, section 4,
// the importance-weighted refinement criterion).
//
// The importance (hr/importance.h) is solved at the start of every judging
// pass on the links the pass judges, so the schedule is: refine radiosity
// and importance links together in one pass with the weights of the last
// gather's hierarchy, then gather radiosity, then (next pass) solve the
// importance again on the refined links. Smits et al. alternate a
// radiosity pass and an importance pass; here one link serves both
// transports, and the error that accepting it makes in each weighs the
// same: the radiosity error rho_r F_rs B_s (receiver side) counts for M
// with A_r y_r, the importance error rho_r F_sr y_r (sent back to s) with
// A_s B_s, and A_r F_rs = A_s F_sr makes both rho_r A_r F_rs B_s y_r,
// BFA's product times the weight w_r = yhat_r / uhat_r. One weight, the
// receiver's, therefore covers the sender side of the importance transport.
//
// w is exactly 1 when every surface is a source (regions = all): the
// view-independent decisions come back bit for bit. Elements that no view
// reaches have w = 0 and keep the links they have. The leaf budget sums
// unweighted errors and is off by default when importance is on
// (hr/settings.cpp).
#include <memory>

#include "hr/checks/check.h"
#include "hr/checks/registry.h"
#include "hr/importance.h"

namespace hrad::hr {
namespace {

class ImportanceCheck final : public RefinementCheck {
  public:
    explicit ImportanceCheck(const ImportanceSettings& s) : on_(s.mode != ImportanceSettings::Mode::Off), field_(s) {}
    const char* name() const override { return "importance"; }
    bool beginPass(const CheckPass& pass) override {
        if (!on_ || !pass.oracle.refinesByError()) return false;
        field_.solve(pass.h, pass.engine.visibility(), pass.recv, pass.pending);
        return true;
    }
    void weigh(const CheckRound& round, size_t i, oracles::LinkEstimate& e) const override {
        e.importance = field_.weight(round.h, round.recv[i]);
    }
    void amend(const CheckRound&, size_t, const oracles::LinkEstimate&,
               oracles::Decision&) const override {}

  private:
    bool on_;
    ImportanceField field_;
};

}  // namespace

std::unique_ptr<RefinementCheck> makeImportanceCheck(const HrSettings& s) {
    return std::make_unique<ImportanceCheck>(s.importance);
}

}  // namespace hrad::hr
