// The error estimate's part of a run (metrics.error_estimate): the residual
// estimate of reference/error_estimate.h computed on the solution, written
// to summary.json as "estimate" with its calibration status, compared with
// the true error where the run has a reference, and a warning when the
// solve's own residual says it lost (or invented) light.
//
// The calibration status is what bench/results/error_estimate.md measured:
// the estimate over the true error (non-emitter L2 against Monte Carlo
// references, the references' own noise removed in quadrature) on a set of
// scenes and eps; a user reads it as "how far to trust this number".
#pragma once

#include <nlohmann/json.hpp>
#include <optional>

#include "core/params.h"
#include "reference/error_estimate.h"
#include "reference/metrics.h"

namespace hrad::experiments {

/// metrics.error_estimate (on by default) and the estimate.* keys.
std::optional<reference::ErrorEstimateSettings> estimateSettings(const Params& settings);

/// The "estimate" object of summary.json, with its calibration status.
nlohmann::json estimateJson(const reference::ErrorEstimate& e);

/// Logs the estimate; warns when the non-emitters' estimated mean ratio is
/// off by more than `lightLostWarning` (2 %) plus three of its standard errors.
void reportEstimate(const reference::ErrorEstimate& e);

/// The estimate over the true error of one run (null where a true error is
/// 0); `mcNoiseL2` is the reference's own non-emitter noise (0: exact).
nlohmann::json estimateAgainstTruth(const reference::ErrorEstimate& e,
                                    const reference::ErrorMetrics& m, double mcNoiseL2);

inline constexpr double lightLostWarning = 0.02;

}  // namespace hrad::experiments
