#include "core/phase_progress.h"

#include <unistd.h>

#include <cstdio>

#include <fmt/format.h>

namespace hrad {

PhaseProgress::PhaseProgress(std::string title, bool enabled)
    : title_(std::move(title)), tty_(isatty(2) != 0) {
    if (enabled) thread_ = std::thread([this] { run(); });
}

PhaseProgress::~PhaseProgress() { done(); }

void PhaseProgress::done() {
    if (!thread_.joinable()) return;
    {
        std::lock_guard lock(mutex_);
        stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
    if (shown_) draw(true);
}

void PhaseProgress::run() {
    std::unique_lock lock(mutex_);
    // Quiet at first: short phases print nothing (the summary has their times).
    if (wake_.wait_for(lock, std::chrono::duration<double>(kQuietSeconds), [&] { return stop_; }))
        return;
    const double interval = tty_ ? 0.25 : kLogInterval;
    do {
        draw(false);
        shown_ = true;
    } while (!wake_.wait_for(lock, std::chrono::duration<double>(interval), [&] { return stop_; }));
}

void PhaseProgress::draw(bool final) {
    const double t = timer_.seconds(), f = fraction_.load();
    std::string text;
    if (final) {
        text = fmt::format("{}: done in {:.1f} s", title_, t);
    } else if (f >= 0.01 && f < 1.0) {
        const std::string left = fmt::format(", about {:.0f} s left", t * (1.0 - f) / f);
        if (tty_) {
            std::string bar(size_t(f * 30), '#');
            bar.resize(30, '.');
            text = fmt::format("{:<24} [{}] {:5.1f}% {:7.1f}s{}", title_, bar, 100.0 * f, t, left);
        } else {
            text = fmt::format("{}: {:.1f}% ({:.1f} s{})", title_, 100.0 * f, t, left);
        }
    } else {
        text = fmt::format("{}: running, {:.0f} s", title_, t);
    }
    if (tty_)
        std::fprintf(stderr, "\r\033[K%s%s", text.c_str(), final ? "\n" : "");
    else
        std::fprintf(stderr, "%s\n", text.c_str());
    std::fflush(stderr);
}

}  // namespace hrad
