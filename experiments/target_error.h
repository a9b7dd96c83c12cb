// A target-error solve (hr.target_error, `hrad solve --target-error X`): the
// hierarchical solve refines in eps stages on one hierarchy
// (hr/stage_controller.h) until the residual estimate of its error
// (reference/error_estimate.h) is at most X, then stops.
//
// After each stage converges the estimate m_k of the chosen metric
// (hr.target_metric: l2_nonemitter or l1_reflected) is computed. If m_k > X
// the next eps is eps_k (X / m_k)^(1/a) x 0.8, a the rate m falls with eps:
// 1/2 until two stages measure it, then log(m_{k-1} / m_k) / log(eps_{k-1} /
// eps_k) clamped to [0.1, 2]; one stage divides eps by 16 at most and by 1.5
// at least. It gives up, saying so, when a stage lowers the estimate by less
// than 5 % (eps is not what holds the error: rays, a cluster model or a
// minimum area may be), after hr.target_stages stages, or when the solve
// stops early (a link, memory or time cap). The summary's "target" says the
// target, whether it was met, every stage's eps, estimate and time, and the
// eps chosen.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/params.h"
#include "reference/error_estimate.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::experiments {

struct TargetSettings {
    double target = 0.0;
    std::string metric = "l2_nonemitter";
    int maxStages = 8;
    /// hr.target_error > 0 turns it on; nothing otherwise.
    static std::optional<TargetSettings> fromParams(const Params& params);
};

class TargetErrorDriver {
  public:
    TargetErrorDriver(const scene::Scene& scene, const transport::Visibility& vis,
                      TargetSettings target, reference::ErrorEstimateSettings estimate,
                      bool progress);

    /// The stage controller's decision for the solution `f` of the stage
    /// judged with `eps` (nothing: stop).
    std::optional<double> afterStage(const scene::RadiosityField& f, double eps);

    /// The estimate of the last stage when no stage followed it (so it is
    /// the estimate of the solve's result), else nothing.
    const reference::ErrorEstimate* finalEstimate() const;
    nlohmann::json summary() const;

  private:
    struct Stage {
        double eps, value, noise, seconds;
    };
    double metricOf(const reference::ErrorEstimate& e) const;

    const scene::Scene* scene_;
    const transport::Visibility* vis_;
    TargetSettings target_;
    reference::ErrorEstimateSettings estimate_;
    bool progress_;
    std::vector<Stage> stages_;
    reference::ErrorEstimate last_;
    bool lastIsFinal_ = false;
    std::string outcome_ = "not run";
};

}  // namespace hrad::experiments
