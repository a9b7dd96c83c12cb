// The error still to come from further gather iterations; see iteration_tail.h.
#include "hr/iteration_tail.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hrad::hr {

double IterationTail::add(const RGB& change, const RGB& reflected, Step step) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    if (step == Step::kBreak) {
        run_.clear();
        irregular_.clear();
        return kInf;
    }
    if (run_.size() > kWindow) {
        run_.erase(run_.begin());
        irregular_.erase(irregular_.begin());
    }
    run_.push_back(change);
    irregular_.push_back(step == Step::kIrregular);
    const size_t w = run_.size() - 1;
    const bool irregular =
        std::find(irregular_.begin(), irregular_.end(), true) != irregular_.end();
    if (w == 0 || (irregular && w < 2)) return kInf;
    double worst = 0.0;
    for (int c = 0; c < 3; ++c) {
        const double scale = std::fabs(reflected[c]);
        if (!(std::fabs(change[c]) > 1e-13 * scale)) continue;  // settled
        const double last = run_[w - 1][c], first = run_[0][c];
        double q = last != 0.0 ? change[c] / last : 0.0;
        if (irregular && q > 0.0) {
            // The slowest step of the window, not the last one.
            for (size_t i = 1; i < w; ++i)
                if (run_[i - 1][c] != 0.0) q = std::max(q, run_[i][c] / run_[i - 1][c]);
        }
        // Measured on two-sided graz.mgf: single-step ratios crossed 1 again
        // and again while the changes fell 300x in 50 iterations.
        if (q >= 1.0 && first != 0.0 && w > 1)
            q = std::pow(std::fabs(change[c] / first), 1.0 / double(w));
        const double tail = q >= 1.0  ? kInf
                            : q > 0.0 ? std::fabs(change[c]) * q / (1.0 - q)
                                      : std::fabs(change[c]);
        worst = std::max(worst, scale > 0 ? tail / scale : tail);
    }
    return worst;
}

}  // namespace hrad::hr
