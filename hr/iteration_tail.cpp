// The error still to come from further gather iterations; see iteration_tail.h.
#include "hr/iteration_tail.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hrad::hr {

double IterationTail::add(const RGB& change, const RGB& reflected, bool clean) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    if (!clean) {
        clean_.clear();
        return kInf;
    }
    if (clean_.size() > kWindow) clean_.erase(clean_.begin());
    clean_.push_back(change);
    const size_t w = clean_.size() - 1;
    if (w == 0) return kInf;
    double worst = 0.0;
    for (int c = 0; c < 3; ++c) {
        const double scale = std::fabs(reflected[c]);
        if (!(std::fabs(change[c]) > 1e-13 * scale)) continue;  // settled
        const double last = clean_[w - 1][c], first = clean_[0][c];
        double q = last != 0.0 ? change[c] / last : 0.0;
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
