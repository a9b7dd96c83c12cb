// The error still to come from further gather iterations on the same links,
// estimated from the changes of the reflected power (hr/solver.h
// "Stopping"): a stationary iteration's error shrinks by a ratio q per
// iteration, so after a change d the remaining change is d q / (1 - q) (the
// geometric tail). q is the ratio of the last two changes of a run of clean
// iterations (nothing refined or extrapolated); where that step does not
// contract (q >= 1) it is taken over the last up to kWindow steps of the
// run, (|d_i| / |d_{i-w}|)^(1/w), so that a channel whose changes shrink
// irregularly (two modes of similar size) still has a rate. Oscillating
// channels (last two changes of opposite sign) use the change itself.
#pragma once

#include <cstddef>
#include <vector>

#include "core/types.h"

namespace hrad::hr {

class IterationTail {
  public:
    static constexpr size_t kWindow = 4;

    /// Records one iteration's change of reflected power (per channel) and
    /// the reflected power after it; `clean` when nothing was refined or
    /// extrapolated in it. Returns the largest relative tail over the
    /// channels: infinite until two clean iterations follow each other, or
    /// when a channel does not contract over the window.
    double add(const RGB& change, const RGB& reflected, bool clean);

  private:
    std::vector<RGB> clean_;  ///< the run's last changes, newest last (<= kWindow + 1)
};

}  // namespace hrad::hr
