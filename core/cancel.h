// Stopping a long computation from another thread: a notebook's Ctrl-C (the
// Python module, python/), a GUI's stop button. The caller owns a
// CancelToken and requests; the computation polls it where it already checks
// its limits (hr/budget.h: before every refinement round and after every
// iteration) and throws hrad::Cancelled, which unwinds the solve like any
// other error: nothing half-done is returned as a result. A token that is
// never requested costs one relaxed atomic load per poll.
//
// Why a token and not a signal handler: the solve runs on worker threads
// while the Python interpreter owns SIGINT; only the interpreter's thread may
// ask Python whether Ctrl-C was pressed (PyErr_CheckSignals), so it sets the
// token and the solver sees it at its next check.
#pragma once

#include <atomic>

#include "core/error.h"

namespace hrad {

/// Thrown where a requested CancelToken is polled.
class Cancelled : public Error {
  public:
    Cancelled() : Error("cancelled: the computation was stopped on request") {}
};

class CancelToken {
  public:
    void request() { flag_.store(true, std::memory_order_relaxed); }
    bool requested() const { return flag_.load(std::memory_order_relaxed); }
    /// Throws Cancelled once request() was called.
    void throwIfRequested() const {
        if (requested()) throw Cancelled();
    }

  private:
    std::atomic<bool> flag_{false};
};

}  // namespace hrad
