// SIGINT and SIGTERM as a request to stop, not a kill (issue 64).
//
// `hrad solve` calls catchInterrupts(): the first SIGINT (Ctrl-C) or SIGTERM
// only records the signal; the hierarchical solver checks interruptSignal()
// where it checks its clock (hr/budget.h), stops refinement and iteration at
// that safe point, and the result is written as a time limit's would be,
// with `interrupted: true` in the summary; the command then exits 128 +
// signal (130, 143). A second signal ends the process at once (the default
// action). Sweeps do not call it: their children are stopped by the signal
// itself and rerun on --resume (experiments/sweep.h).
//
// The flag is the one process-wide variable hrad keeps: a signal handler can
// reach nothing else (POSIX allows it only volatile sig_atomic_t).
#pragma once

namespace hrad {

/// Installs the handlers for SIGINT and SIGTERM.
void catchInterrupts();
/// The signal received since catchInterrupts (SIGINT, SIGTERM), 0 if none.
int interruptSignal();

}  // namespace hrad
