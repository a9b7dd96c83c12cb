// CPU time, not wall time: what a thread or the process actually computed.
//
// Wall time summed over threads counts the time a thread waits for a core
// (2 cores, 4 runnable threads: twice the CPU used; the "CPU s by kind" log
// line once reported 100.6 s for 41.6 s of CPU, issue 63). These read the
// kernel's per-thread and per-process CPU clocks (POSIX
// clock_gettime(CLOCK_THREAD_CPUTIME_ID / CLOCK_PROCESS_CPUTIME_ID): user +
// system time, nanosecond resolution on Linux).
#pragma once

#include <time.h>

namespace hrad {

/// CPU seconds the calling thread has used.
inline double threadCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// CPU seconds the process (all its threads) has used.
inline double processCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace hrad
