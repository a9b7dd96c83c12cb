// Accelerating the gather iteration's tail, between the solver's
// iterations (HrSolver::solveOnce): relaxation of the few root patches that
// carry most of the change, and Aitken extrapolation of a geometric tail.
//
// Relaxation (hr.relax_share, hr.relax_fraction, hr.relax_sweeps). A nearly
// closed gap between surfaces of high reflectance keeps its light for many
// bounces (the bathroom's mirror: two panes a few millimetres apart, both
// 0.99), a slow mode of the iteration under the room's fast ones. After a
// quiet iteration, the fewest root patches that carry `share` of the change
// of the last two iterations are relaxed alone with Gauss-Seidel sweeps
// (Hierarchy::relax; Cohen & Wallace 1993, section 5.3) when they are at
// most `fraction` of all root patches.
//
// Extrapolation (hr.extrapolate). When the reflected power's change shrinks
// by a stable ratio q per iteration (within 5 % twice in a row, 0 < q <
// 0.99999), every leaf is moved by q / (1 - q) times its last change (the
// sum of the geometric tail; Aitken's delta-squared process), at most every
// other iteration; the following iterations correct any error, since the
// fixed point is the same.
//
// Measurements: papers/notes/2026-12-01-hr-solver-notes.md.
#pragma once

#include <cstdint>
#include <vector>

#include "hr/hierarchy.h"
#include "hr/settings.h"

namespace hrad::hr {

struct IterationRecord;

class IterationAccelerator {
  public:
    IterationAccelerator(const HrSettings& s, const Hierarchy& h);
    /// An iteration whose refinement touched at most this share of the
    /// links is quiet: relaxation and extrapolation go on.
    static bool quiet(uint64_t refined, uint64_t links);
    /// Relaxes the patches carrying the change, after a quiet iteration;
    /// fills rec's relaxation fields. `lastReflected` sets the scale.
    void relax(Hierarchy& h, bool quiet, IterationRecord& rec, const RGB& lastReflected);
    /// Extrapolates when the tail is geometric; returns the reflected power after it.
    RGB extrapolate(Hierarchy& h, bool quiet, IterationRecord& rec, const RGB& reflected,
                    const RGB& lastReflected);
    /// Keeps the root patches' radiosities for the next relaxation.
    void remember(const Hierarchy& h);

  private:
    const HrSettings& s_;
    uint32_t np_;
    bool relaxOn_;
    std::vector<RGB> prevRoots_;
    std::vector<double> prevRootChange_;
    std::vector<RGB> previousB_, previousHi_;
    RGB lastChange_{0.0}, lastRatio_{0.0};
    int quietIterations_ = 0, sinceExtrapolation_ = 2;
};

}  // namespace hrad::hr
