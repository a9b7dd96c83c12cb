// A target-error solve; see target_error.h.
#include "experiments/target_error.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/log.h"

namespace hrad::experiments {

using nlohmann::json;

std::optional<TargetSettings> TargetSettings::fromParams(const Params& p) {
    Params::Scope scope(p, "target error");
    TargetSettings t;
    t.target = p.getDouble({"hr.target_error",
                            "refine in eps stages until the error estimate is at most this "
                            "(0: off; experiments/target_error.h)"},
                           0.0, 0.0, 1.0);
    t.metric = p.getEnum({"hr.target_metric", "the estimated error hr.target_error bounds"},
                         t.metric, {"l2_nonemitter", "l1_reflected"});
    t.maxStages = int(p.getInt({"hr.target_stages", "hr.target_error: eps stages at most"},
                               t.maxStages, 1, 64));
    if (!(t.target > 0.0)) return std::nullopt;
    return t;
}

TargetErrorDriver::TargetErrorDriver(const scene::Scene& scene, const transport::Visibility& vis,
                                     TargetSettings target,
                                     reference::ErrorEstimateSettings estimate, bool progress)
    : scene_(&scene), vis_(&vis), target_(std::move(target)), estimate_(estimate),
      progress_(progress) {}

double TargetErrorDriver::metricOf(const reference::ErrorEstimate& e) const {
    return target_.metric == "l1_reflected" ? e.l1Reflected : e.l2NonEmitter;
}

std::optional<double> TargetErrorDriver::afterStage(const scene::RadiosityField& f, double eps) {
    last_ = reference::estimateError(*scene_, *vis_, f, estimate_, progress_);
    lastIsFinal_ = true;
    const double m = metricOf(last_);
    stages_.push_back(Stage{eps, m, last_.noiseL2, last_.seconds});
    spdlog::info("target error {:.3g}: eps {:.3g} gives an estimated {} of {:.3g}",
                 target_.target, eps, target_.metric, m);
    if (m <= target_.target) {
        outcome_ = "met";
        return std::nullopt;
    }
    const size_t k = stages_.size();
    double a = 0.5;
    if (k >= 2) {
        const Stage& prev = stages_[k - 2];
        if (!(m < 0.95 * prev.value)) {
            outcome_ = "stalled";
            spdlog::warn("target error {:.3g} not reached: lowering eps from {:.3g} to {:.3g} "
                         "moved the estimated {} only from {:.3g} to {:.3g}; eps is not what "
                         "holds the error (rays, the cluster model or the minimum area may be)",
                         target_.target, prev.eps, eps, target_.metric, prev.value, m);
            return std::nullopt;
        }
        a = std::clamp(std::log(prev.value / m) / std::log(prev.eps / eps), 0.1, 2.0);
    }
    if (int(k) >= target_.maxStages) {
        outcome_ = "stages";
        spdlog::warn("target error {:.3g} not reached after hr.target_stages = {} stages "
                     "(estimate {:.3g})",
                     target_.target, target_.maxStages, m);
        return std::nullopt;
    }
    const double factor = std::clamp(std::pow(target_.target / m, 1.0 / a) * 0.8, 1.0 / 16, 1.0 / 1.5);
    lastIsFinal_ = false;
    outcome_ = "stopped early";  // until a later stage says otherwise
    return eps * factor;
}

const reference::ErrorEstimate* TargetErrorDriver::finalEstimate() const {
    return lastIsFinal_ ? &last_ : nullptr;
}

json TargetErrorDriver::summary() const {
    json stages = json::array();
    double seconds = 0;
    for (const Stage& s : stages_) {
        stages.push_back(json{{"eps", s.eps}, {"estimate", s.value}, {"noise", s.noise},
                              {"estimate_seconds", s.seconds}});
        seconds += s.seconds;
    }
    return json{{"target", target_.target},
                {"metric", target_.metric},
                {"outcome", outcome_},
                {"met", outcome_ == "met"},
                {"estimate", stages_.empty() ? json(nullptr) : json(stages_.back().value)},
                {"eps", stages_.empty() ? json(nullptr) : json(stages_.back().eps)},
                {"stages", stages},
                {"estimate_seconds", seconds}};
}

}  // namespace hrad::experiments
