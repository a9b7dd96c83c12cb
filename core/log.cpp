#include "core/log.h"

#include <unistd.h>

#include <cstdio>

#include <spdlog/sinks/stdout_color_sinks.h>

namespace hrad {

namespace {
constexpr double kQuietSeconds = 2.0;  ///< as PhaseProgress::kQuietSeconds
}  // namespace

void initLogging(const std::string& level) {
    // Callable again (the Python module's hrad.log_level): the logger is made once.
    auto logger = spdlog::get("hrad");
    if (!logger) logger = spdlog::stderr_color_mt("hrad");
    logger->set_pattern("[%l] %v");
    if (level == "quiet")
        logger->set_level(spdlog::level::warn);
    else if (level == "debug")
        logger->set_level(spdlog::level::debug);
    else
        logger->set_level(spdlog::level::info);
    spdlog::set_default_logger(logger);
}

ProgressBar::ProgressBar(std::string title, uint64_t total, bool enabled)
    : title_(std::move(title)), total_(total), enabled_(enabled), tty_(isatty(2) != 0) {}

ProgressBar::~ProgressBar() { done(); }

void ProgressBar::add(uint64_t n) {
    uint64_t c = current_.fetch_add(n) + n;
    if (!enabled_) return;
    double t = timer_.seconds();
    // Phases under ~2 s print nothing (the summary reports them).
    if (t < kQuietSeconds) return;
    // Redraw at most 10x per second on a terminal; every 10 s otherwise.
    double interval = tty_ ? 0.1 : 10.0;
    if (t - lastDraw_ < interval) return;
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock() || t - lastDraw_ < interval) return;
    lastDraw_ = t;
    draw(c, false);
}

void ProgressBar::done() {
    if (finished_) return;
    finished_ = true;
    // Short phases print nothing: the summary reports them.
    if (enabled_ && timer_.seconds() > kQuietSeconds) draw(total_, true);
}

namespace {
/// ", about 42s left": a linear extrapolation of the elapsed time, once 1 %
/// is done.
std::string eta(double frac, double elapsed, bool final) {
    if (final || !(frac >= 0.01) || frac >= 1.0) return "";
    return fmt::format(", about {:.0f}s left", elapsed * (1.0 - frac) / frac);
}
}  // namespace

void ProgressBar::draw(uint64_t current, bool final) {
    double frac = total_ ? std::min(1.0, double(current) / double(total_)) : 1.0;
    double t = timer_.seconds();
    if (tty_) {
        int width = 30, filled = int(frac * width);
        std::string bar(filled, '#');
        bar.resize(width, '.');
        std::fprintf(stderr, "\r%-24s [%s] %5.1f%% %7.1fs%s%s", title_.c_str(), bar.c_str(),
                     100.0 * frac, t, eta(frac, t, final).c_str(), final ? "\n" : "");
    } else {
        std::fprintf(stderr, "%s: %.1f%% (%.1fs%s)\n", title_.c_str(), 100.0 * frac, t,
                     eta(frac, t, final).c_str());
    }
    std::fflush(stderr);
}

}  // namespace hrad
