// After each eps stage has converged, a controller may ask for another stage
// on the same hierarchy with a smaller eps: refinement goes on from the links
// it has (hr.eps_schedule's stages, chosen while the solve runs instead of
// before). What a target-error solve (experiments/target_error.h) is built
// on: it estimates the error of the stage's solution and picks the next eps.
// hr/ knows nothing of the estimate; the controller brings it.
#pragma once

#include <optional>

namespace hrad::hr {

class Hierarchy;

class StageController {
  public:
    virtual ~StageController() = default;
    /// Called when the stage judged with `eps` has converged, with the
    /// hierarchy as it then is (push-pulled). A value below `eps` runs
    /// another stage with it; nothing ends the solve.
    virtual std::optional<double> afterStage(const Hierarchy& h, double eps) = 0;
};

}  // namespace hrad::hr
