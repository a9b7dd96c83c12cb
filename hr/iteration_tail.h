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
//
// An iteration whose relaxation of hot patches stopped at its budget before
// its target (hr/solver.h, "Relaxation") changes the solution by more than
// one gather, by an amount that varies from one iteration to the next. Such
// iterations stay in the run but mark it irregular: its rate is then the
// largest single-step ratio over the window (at least two steps), not the
// last one, so that one step the relaxation made look fast does not stop
// the solve. Such iterations can be all there is once refinement stops: on
// office:2:12 every one relaxed about 300 patches without reaching the
// target, while the changes fell with a steady ratio of about 0.4
// (bench/results/large_scenes.md, "Stopping after a relaxation stopped by
// its budget").
#pragma once

#include <cstddef>
#include <vector>

#include "core/types.h"

namespace hrad::hr {

class IterationTail {
  public:
    static constexpr size_t kWindow = 4;

    /// What happened in an iteration besides one gather.
    enum class Step {
        kClean,      ///< nothing else: its change continues the run
        kIrregular,  ///< a relaxation stopped by its budget: in the run, judged by the window
        kBreak,      ///< refined or extrapolated: starts a new run
    };

    /// Records one iteration's change of reflected power (per channel) and
    /// the reflected power after it. Returns the largest relative tail over
    /// the channels: infinite until two iterations of one run follow each
    /// other (three when the run is irregular), or when a channel does not
    /// contract over the window.
    double add(const RGB& change, const RGB& reflected, Step step);

  private:
    std::vector<RGB> run_;         ///< the run's last changes, newest last (<= kWindow + 1)
    std::vector<bool> irregular_;  ///< per entry of run_: a kIrregular step
};

}  // namespace hrad::hr
