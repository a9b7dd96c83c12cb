// What eps is a fraction of (hr.eps_power; hr/solver.h, "What eps is a
// fraction of"). The oracles compare a power with eps times a power of the
// scene. Hanrahan, Salzman & Aupperle (1991) take the emitted power; the
// error metrics measure the reflected power B - E, which in a scene whose
// light mostly leaves or is absorbed is a small part of it (one-sided
// graz.mgf: 1 %). The tracker follows the reflected power iteration by
// iteration and gives the power each judging pass compares with:
//   Smaller    the smaller of the emitted power and the reflected power the
//              iteration is heading to (the default);
//   Emitted    the emitted power;
//   Reflected  the reflected power so far (the emitted power before the
//              first gather).
// The prediction: a stationary iteration's changes shrink by a ratio q per
// iteration, so after a change d the power still to come is d q / (1 - q)
// (the geometric tail of hr/iteration_tail.h, applied to the power itself).
// Judging with the power so far instead would over-refine: after the first
// bounces it is a part of the final one, and links are never coarsened.
#pragma once

#include <string>
#include <vector>

#include "core/types.h"

namespace hrad::hr {

enum class EpsPower { Emitted, Reflected, Smaller };

/// The names of the hr.eps_power values, in the enum's order.
const std::vector<std::string>& epsPowerNames();
/// The name of an hr.eps_power value ("emitted", "reflected", "smaller").
const char* epsPowerName(EpsPower e);
/// The value of a name of epsPowerNames() (checked by the caller's
/// Params::getEnum; anything else is Emitted).
EpsPower epsPowerFromName(const std::string& name);

/// The reflected power (max channel) a Jacobi-like iteration is heading to,
/// from its reflected powers after three consecutive iterations (older,
/// old, now). Per channel: where the last two changes grow the power and
/// shrink by a ratio q < 1, the power so far plus d q / (1 - q); where the
/// power fell (refinement closed a leak) or has settled, the power so far.
/// Infinite where a channel grows without a shrinking change (no basis for
/// a prediction).
double predictedReflected(const RGB& older, const RGB& old, const RGB& now);

class EpsPowerTracker {
  public:
    /// `emitted`: the scene's emitted power (max channel, > 0);
    /// `reflectedBefore`: the reflected power before the first gather.
    EpsPowerTracker(EpsPower mode, double emitted, const RGB& reflectedBefore);

    /// Records the reflected power after an iteration.
    void add(const RGB& reflected);

    /// The power the next judging pass compares eps with. Smaller: the
    /// emitted power until two iterations are known; where the last three
    /// give no prediction (a relaxation or an extrapolation broke the
    /// ratio of their changes), the last prediction, or the power so far
    /// where that is larger.
    double power() const { return power_; }

  private:
    EpsPower mode_;
    double emitted_;
    RGB seen_[3];          ///< the last reflected powers, newest last
    int count_ = 0;        ///< entries of seen_ filled
    double predicted_;     ///< the last finite prediction (infinite: none yet)
    double power_;
};

}  // namespace hrad::hr
