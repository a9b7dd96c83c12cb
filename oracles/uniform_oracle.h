// `uniform`: subdivide every element to a fixed depth.
//
// The uniform-mesh baseline inside the hierarchical solver: every link is
// refined on both sides until both elements reach `level` (or may no longer
// subdivide), so the solution is the classical radiosity method on a uniform
// mesh with all element pairs linked (Cohen & Wallace 1993, ch. 5), solved by
// the same gather/push-pull machinery. Comparing it with `bfa` and `ff` at
// equal accuracy isolates what hierarchy buys. It is blind to hr.basis on
// purpose: the mesh is the same for every basis, so that comparing bases on
// it isolates what the basis buys (papers/studies/bases.toml).
//
// Settings:
//   level   int  3   target subdivision depth of every element (0..20)
#pragma once

#include "oracles/oracle.h"

namespace hrad::oracles {

class UniformOracle final : public Oracle {
  public:
    struct Settings {
        int level = 3;
        static Settings fromParams(const Params& p);
    };
    explicit UniformOracle(Settings s) : s_(s) {}
    Decision decide(const LinkEstimate& e) const override;
    std::string name() const override { return "uniform"; }
    bool refinesByError() const override { return false; }
    std::string describe() const override;

  private:
    Settings s_;
};

}  // namespace hrad::oracles
