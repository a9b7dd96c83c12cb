// Running a long C++ call from Python: on a worker thread with the GIL
// released, while the interpreter's thread polls for Ctrl-C
// (PyErr_CheckSignals every 50 ms). Ctrl-C requests the CancelToken
// (core/cancel.h) handed to the work; an hr solve sees it before its next
// refinement round or after its iteration (hr/budget.h) and stops. The call
// then raises KeyboardInterrupt. Work that does not poll the token (the full
// matrix, Monte Carlo, rendering) runs to its end first.
//
// Why a worker thread: only the main thread may run Python's signal
// handlers, and it must not hold the GIL while the solve runs (other Python
// threads go on), so it waits for the worker and checks for signals.
#pragma once

#include <functional>

#include "core/cancel.h"

namespace hrad::python {

/// Runs work(token) as above (the work may request the token itself, e.g.
/// when a Python callback it calls raises). C++ exceptions of the work are rethrown here
/// (pybind11 turns them into hrad.InputError / hrad.Error); Ctrl-C raises
/// KeyboardInterrupt once the work has returned.
void runInterruptible(const std::function<void(CancelToken&)>& work);

}  // namespace hrad::python
