// Logging and progress display on stderr.
//
// Logging goes through spdlog's default logger (stderr, "[level] message").
// ProgressBar draws a single updating line when stderr is a terminal and a
// few plain lines otherwise (so CI logs stay short). It is safe to call
// update() from several threads.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

#include <spdlog/spdlog.h>

#include "core/timer.h"

namespace hrad {

/// Sets up the default logger: "quiet" (warnings), "info" or "debug".
void initLogging(const std::string& level);

class ProgressBar {
  public:
    ProgressBar(std::string title, uint64_t total, bool enabled = true);
    ~ProgressBar();
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;

    void add(uint64_t n);
    void done();

  private:
    void draw(uint64_t current, bool final);

    std::string title_;
    uint64_t total_;
    bool enabled_, tty_, finished_ = false;
    std::atomic<uint64_t> current_{0};
    std::mutex mutex_;
    double lastDraw_ = -1.0;
    Timer timer_;
};

}  // namespace hrad
