// The error estimate's part of a run; see estimate_report.h.
#include "experiments/estimate_report.h"

#include <cmath>

#include "core/log.h"

namespace hrad::experiments {

using nlohmann::json;

namespace {

/// bench/results/error_estimate.md: what the calibration study measured.
struct Calibration {
    int scenes, solves;
    double low, high;       ///< range of estimate / true non-emitter L2
    double within;          ///< share of solves inside [0.67, 1.5]
    const char* page;
};
constexpr Calibration kCalibration{7, 14, 0.43, 1.79, 11.0 / 14.0, "bench/results/error_estimate.md"};

}  // namespace

std::optional<reference::ErrorEstimateSettings> estimateSettings(const Params& s) {
    if (!s.getBool({"metrics.error_estimate",
                    "estimate the solve's error from its transport residual "
                    "(reference/error_estimate.h): summary \"estimate\""},
                   true))
        return std::nullopt;
    return reference::ErrorEstimateSettings::fromParams(s, "estimate");
}

json estimateJson(const reference::ErrorEstimate& e) {
    json cal = {{"page", kCalibration.page}};
    if (kCalibration.solves > 0) {
        cal["scenes"] = kCalibration.scenes;
        cal["solves"] = kCalibration.solves;
        cal["ratio_range"] = json::array({kCalibration.low, kCalibration.high});
        cal["share_within_0.67_1.5"] = kCalibration.within;
    } else {
        cal["status"] = "not calibrated";
    }
    // Noise above the estimate itself: one draw of a cross product that
    // is unbiased but too noisy to trust (Lost Empire at 8 samples a region:
    // 0.43x the true error, bench/results/error_estimate.md).
    const bool noisy = e.noiseL2 > e.l2NonEmitter;
    return json{{"method", "residual"},
                {"noise_dominated", noisy},
                {"l2_nonemitter", e.l2NonEmitter},
                {"l1_reflected", e.l1Reflected},
                {"mean_ratio_nonemitter", e.meanRatio},
                {"noise_l2_nonemitter", e.noiseL2},
                {"mean_ratio_noise", e.meanRatioNoise},
                {"residual_l2_nonemitter", e.residualL2},
                {"regions", e.regions},
                {"samples_per_region", e.samplesPerRegion},
                {"rays", e.rays},
                {"iterations", e.iterations},
                {"seconds", e.seconds},
                {"calibration", cal}};
}

void reportEstimate(const reference::ErrorEstimate& e) {
    spdlog::info(
        "error estimate (residual): non-emitters L2 {:.3g}, reflected L1 {:.3g}, mean ratio "
        "{:.4f} (noise {:.2g}, {} regions x {} samples, {:.2f} s)",
        e.l2NonEmitter, e.l1Reflected, e.meanRatio, e.noiseL2, e.regions, e.samplesPerRegion,
        e.seconds);
    if (e.noiseL2 > e.l2NonEmitter)
        spdlog::warn("error estimate: its own noise ({:.2g}) is above the estimate ({:.2g}); "
                     "raise estimate.samples or estimate.min_samples before trusting it",
                     e.noiseL2, e.l2NonEmitter);
    const double off = std::fabs(e.meanRatio - 1.0);
    if (off > lightLostWarning + 3.0 * e.meanRatioNoise)
        spdlog::warn(
            "the solution's non-emitting surfaces hold {:.1f} % {} light than its own transport "
            "gives them (residual estimate, mean ratio {:.3f}): the solve {} light; see "
            "estimate.* and the error estimate's page {}",
            100.0 * off, e.meanRatio < 1 ? "less" : "more", e.meanRatio,
            e.meanRatio < 1 ? "lost" : "invented", kCalibration.page);
}

json estimateAgainstTruth(const reference::ErrorEstimate& e, const reference::ErrorMetrics& m,
                          double mcNoiseL2) {
    // The reference's own noise adds in quadrature to the measured L2.
    const double trueL2 = std::sqrt(std::max(
        0.0, m.l2NonEmitLum * m.l2NonEmitLum - mcNoiseL2 * mcNoiseL2));
    auto ratio = [](double est, double truth) { return truth > 0 ? json(est / truth) : json(nullptr); };
    return json{{"true_l2_nonemitter", trueL2},
                {"l2_nonemitter_ratio", ratio(e.l2NonEmitter, trueL2)},
                {"l1_reflected_ratio", ratio(e.l1Reflected, m.l1ReflLum)},
                {"mean_ratio_estimated", e.meanRatio},
                {"mean_ratio_true", m.meanRatioNonEmit}};
}

}  // namespace hrad::experiments
