// Progress of a phase whose work is not counted in advance.
//
// ProgressBar (core/log.h) needs a total; the pre-iteration phases of a large
// solve (loading, the ray-tracing structure, reachability, the cluster tree,
// the hand-over openness) have none that is cheap to know, and on a 1 M
// triangle scene they printed nothing for 206 s (issue 63). PhaseProgress
// shows that such a phase is running: silent for its first kQuietSeconds,
// then on a terminal one updating line with the elapsed time (and a bar with
// the time left once the phase reports a fraction done, setFraction), and
// otherwise (logs, CI) a plain line every kLogInterval seconds, never a bar.
// When it showed anything it ends with one line "TITLE: done in 14.2 s".
// A helper thread draws, so the phase itself needs no calls at all.
#pragma once

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

#include "core/timer.h"

namespace hrad {

class PhaseProgress {
  public:
    static constexpr double kQuietSeconds = 2.0;
    static constexpr double kLogInterval = 10.0;

    /// Starts showing `title` (when `enabled`) after kQuietSeconds.
    PhaseProgress(std::string title, bool enabled);
    ~PhaseProgress();
    PhaseProgress(const PhaseProgress&) = delete;
    PhaseProgress& operator=(const PhaseProgress&) = delete;

    /// The share of the phase done, in [0, 1] (optional): adds a bar and the time left.
    void setFraction(double f) { fraction_.store(f); }
    /// Ends the phase now (the destructor calls it).
    void done();

  private:
    void run();
    void draw(bool final);

    std::string title_;
    bool tty_ = false, shown_ = false;
    std::atomic<double> fraction_{-1.0};
    Timer timer_;
    std::mutex mutex_;
    std::condition_variable wake_;
    bool stop_ = false;
    std::thread thread_;
};

}  // namespace hrad
