// What eps is a fraction of; see eps_power.h.
#include "hr/eps_power.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hrad::hr {

const std::vector<std::string>& epsPowerNames() {
    static const std::vector<std::string> names{"emitted", "reflected", "smaller"};
    return names;
}

const char* epsPowerName(EpsPower e) { return epsPowerNames()[size_t(e)].c_str(); }

EpsPower epsPowerFromName(const std::string& name) {
    const auto& names = epsPowerNames();
    const auto it = std::find(names.begin(), names.end(), name);
    return it == names.end() ? EpsPower::Emitted : EpsPower(it - names.begin());
}

double predictedReflected(const RGB& older, const RGB& old, const RGB& now) {
    double worst = 0.0;
    for (int c = 0; c < 3; ++c) {
        const double d = now[c] - old[c], dPrev = old[c] - older[c];
        if (d <= 1e-12 * std::fabs(now[c])) {  // fell or settled
            worst = std::max(worst, now[c]);
            continue;
        }
        const double q = dPrev > 0.0 ? d / dPrev : -1.0;
        if (!(q > 0.0 && q < 1.0)) return std::numeric_limits<double>::infinity();
        worst = std::max(worst, now[c] + d * q / (1.0 - q));
    }
    return worst;
}

EpsPowerTracker::EpsPowerTracker(EpsPower mode, double emitted, const RGB& reflectedBefore)
    : mode_(mode),
      emitted_(emitted),
      predicted_(std::numeric_limits<double>::infinity()),
      power_(emitted) {
    add(reflectedBefore);
}

void EpsPowerTracker::add(const RGB& reflected) {
    if (count_ == 3) {
        seen_[0] = seen_[1];
        seen_[1] = seen_[2];
        count_ = 2;
    }
    seen_[count_++] = reflected;
    const double now = maxComponent(reflected);
    switch (mode_) {
        case EpsPower::Emitted: power_ = emitted_; break;
        case EpsPower::Reflected: power_ = now > 0.0 ? now : emitted_; break;
        case EpsPower::Smaller: {
            if (count_ < 3) break;  // the emitted power
            double p = predictedReflected(seen_[0], seen_[1], seen_[2]);
            if (std::isfinite(p))
                predicted_ = p;
            else if (std::isfinite(predicted_))
                p = std::max(predicted_, now);
            power_ = p > 0.0 ? std::min(emitted_, p) : emitted_;
            break;
        }
    }
}

}  // namespace hrad::hr
