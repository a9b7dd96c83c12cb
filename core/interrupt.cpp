#include "core/interrupt.h"

#include <signal.h>

#include <csignal>

namespace hrad {

namespace {

volatile std::sig_atomic_t caught = 0;

extern "C" void onInterrupt(int sig) {
    if (caught != 0) {  // the second one: as if no handler were installed
        ::signal(sig, SIG_DFL);
        ::raise(sig);
        return;
    }
    caught = sig;
}

}  // namespace

void catchInterrupts() {
    struct sigaction sa {};
    sa.sa_handler = onInterrupt;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
}

int interruptSignal() { return int(caught); }

}  // namespace hrad
