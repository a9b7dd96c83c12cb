// One poll for every long loop (issue 64): the caller's CancelToken
// (core/cancel.h, the Python module: throws Cancelled, nothing half-done is
// returned) and SIGINT/SIGTERM (core/interrupt.h, the command line: true,
// the loop stops at this safe point and its result is marked interrupted).
// The full-matrix, progressive and Monte Carlo solvers (reference/) and the
// hierarchical solver's initial linking poll it once per row, shot or
// region; the refinement budget (hr/budget.h) polls the same two.
#pragma once

#include "core/cancel.h"
#include "core/interrupt.h"

namespace hrad {

struct StopPoll {
    const CancelToken* cancel = nullptr;
    /// Throws Cancelled when the token was requested; true once a signal came.
    bool operator()() const {
        if (cancel) cancel->throwIfRequested();
        return interruptSignal() != 0;
    }
};

}  // namespace hrad
