#include "oracles/uniform_oracle.h"

#include <fmt/format.h>

namespace hrad::oracles {

UniformOracle::Settings UniformOracle::Settings::fromParams(const Params& p) {
    Settings s;
    s.level = int(p.getInt({"level", "uniform oracle: refine every link to this quadtree depth"},
                           s.level, 0, 20));
    return s;
}

Decision UniformOracle::decide(const LinkEstimate& e) const {
    // Clusters are always opened: the uniform mesh lives on surfaces.
    bool r = e.receiverIsCluster || e.receiverLevel < s_.level;
    bool s = e.senderIsCluster || e.senderLevel < s_.level;
    Decision d = r && s ? Decision::RefineBoth
                 : r    ? Decision::RefineReceiver
                 : s    ? Decision::RefineSender
                        : Decision::Accept;
    LinkEstimate c = e;
    // Do not let constrain() move refinement to a side already at depth.
    c.receiverCanSubdivide = e.receiverCanSubdivide && r;
    c.senderCanSubdivide = e.senderCanSubdivide && s;
    return constrain(d, c);
}

std::string UniformOracle::describe() const { return fmt::format("uniform(level={})", s_.level); }

}  // namespace hrad::oracles
