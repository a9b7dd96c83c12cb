// Running one point: load, solve, compare with a reference, write artefacts,
// and describe everything in one JSON summary. `hrad solve` and `hrad sweep`
// both go through runPoint(), so a sweep row and a solve's summary.json hold
// the same fields.
//
// Point settings (PointSpec::settings):
//   solver        string  "hr"   "hr" | "full-matrix"
//   hr.*, oracle.*, ff.*, cluster.*     hr::HrSettings (solver = hr)
//   fm.*                                reference::FullMatrixSettings (solver = full-matrix)
//   mgf.*, obj.*, ply.*, validate       scene::loadScene
//   render.*      render::RenderSettings, plus render.exposure (PNG and PLY)
// Reference settings (PointSpec::reference, the study's [reference] table):
//   kind          string  "none"  "none" | "full-matrix" | "montecarlo"
//   fm.*          reference::FullMatrixSettings (kind = full-matrix)
//   mc.*          reference::MonteCarloSettings (kind = montecarlo)
// Every key is read by the component it belongs to, then reportUnused()
// rejects the rest, with the file:line the key came from.
//
// Summary JSON (the fields of summary.json and of a results-store row):
//   hrad_version, build_type, host, date, scene, scene_label, settings,
//   reference_settings, scene_info{...}, solver, solver_settings, oracle,
//   converged, link_cap_hit, memory_budget_hit, time_limit_hit, interrupted
//   (SIGINT/SIGTERM, core/interrupt.h), min_area,
//   error_estimate (each receiver's kernel range and averaged senders, summed:
//   an upper estimate), error_estimate_leaves and error_estimate_points
//   (hr/receiver_error.h leafAverageError: the error of the leaves' averages
//   from the push of coarse surface links, and of the irradiance at the
//   leaves' points; null for a polynomial basis), stand_in_power_share,
//   noise_estimate (hr/noise.h: the
//   relative standard deviation of the reflected power that the solve's own
//   rays leave, max channel), noise{reflected_power_sd[3], direct_sd[3],
//   amplification[3], relative, l2_nonemitter_direct, noisy_links},
//   counts{elements, leaves, links, initial_links, initial_pairs, links_ss, links_sc,
//          links_cs, links_cc (surface/cluster receiver-sender), rays, form_factors,
//          deferred_links_computed, deferred_links_left, unopened_links, stand_in_links,
//          stand_in_rays, near_stand_ins_made, near_stand_in_rays, stand_in_links_final,
//          handover_rays,
//          handover_by_openness, handover_by_cosine, handover_capped, iterations},
//   timings{load, visibility_build, [cluster_build], [handover_openness], linking,
//           refine, [stand_in], [near_stand_in], gather, push_pull, error_estimate,
//           noise_estimate, solve_total, reference, error,
//           render}   (seconds)
//   history[{iteration, stage, eps, links, elements, leaves, refined_links,
//            rays, form_factors, residual, reflected_power, refine_s, gather_s,
//            push_pull_s, element_bytes, link_bytes, peak_rss}]
//   memory{<category>: bytes, peak_rss},
//   bytes_per_link{link_storage, links_and_elements, all_told (every memory
//                  counter over the links)}, radiosity_power,
//   error{l1_lum, l2_lum, linf_lum, l1_rgb, l2_rgb, linf_rgb, l1_reflected_lum,
//         l2_reflected_lum, l1_nonemitter_lum, l2_nonemitter_lum, mean_ratio_nonemitter,
//         dark_reflected_fraction, dark_regions, regions, reference, reference_seconds,
//         reference_cached, reference_stats, reflected_by_material[{material, area,
//         reflected, reference_reflected}] (ten at most, largest difference first),
//         [mc_stderr_l2_lum, mc_stderr_l2_rgb, mc_stderr_l2_nonemitter_lum]},
//   artefacts{...}, wall_seconds, cpu_seconds (the process's CPU time, all threads)
//
// Error per iteration (outputs.history_error): the reference is computed
// before the solve and an HrSolver iteration hook records the L2 luminance
// error after every iteration (history[].l2_lum, the iterations table's
// l2_lum column); the hook's time is in no phase's timing.
//
// The Monte Carlo reference's own uncertainty is reported as the relative L2
// norm of its standard errors, the same weighting as the L2 error:
//   mc_stderr_l2 = sqrt(sum_k A_k |sigma_k|^2) / sqrt(sum_k A_k |R_k|^2)
// (for luminance |sigma_k| = luminance(sigma_k), an upper bound of the
// luminance's standard error since the channel errors may be correlated). An
// L2 error of the same order as this number is not resolved by the reference.
// mc_stderr_l2_nonemitter_lum is the same norm over the regions of the
// non-emitting patches, the norm of l2_nonemitter_lum.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/cancel.h"
#include "experiments/solvers.h"
#include "experiments/study.h"

namespace hrad::reference {
struct ErrorMetrics;
}

namespace hrad::experiments {

/// What a run computed, for a caller that keeps it in memory (the Python
/// module, python/): the scene and its visibility, which the field refers
/// to, and the field with its owner. runPoint hands over the solve's output;
/// prepareReference the reference (solved.field, kept alive by
/// solved.owner) and, for Monte Carlo, its standard errors per region.
struct RunOutput {
    std::shared_ptr<const scene::Scene> scene;
    std::shared_ptr<const transport::Visibility> visibility;
    SolveOutput solved;
    std::vector<RGB> stdError;
};

struct RunContext {
    /// Reference cache folder; "" = reference::defaultCacheDir().
    std::string cacheDir;
    /// false: compute the reference in memory, never touch the cache.
    bool useCache = true;
    bool progress = false;
    /// Where exr/ply artefacts go ("" with outputs requested: an error).
    std::filesystem::path artefactDir;
    /// Called with the summary so far after the solve and after the error
    /// (hrad solve writes summary.json each time: nothing is lost if a later
    /// step fails).
    std::function<void(const nlohmann::json&)> checkpoint;
    /// A caller's stop request (core/cancel.h): handed to the solve (which
    /// throws hrad::Cancelled) and polled between the run's phases.
    const CancelToken* cancel = nullptr;
    /// Called with the solution (runPoint, right after the solve) or the
    /// reference (prepareReference) that the run would otherwise drop.
    std::function<void(const RunOutput&)> keep;
    /// Handed to the solve (SolveContext::onRecord): every history record
    /// as it is made.
    std::function<void(const nlohmann::json&)> onRecord;
};

/// Builds every component's settings from the point's Params exactly as
/// runPoint does, without loading the scene or solving, then reports unused
/// keys. Throws InputError (with the study's file:line) for unknown keys,
/// unknown strategy names and out-of-range values.
void validatePoint(const PointSpec& point);

/// Runs the point and returns its summary (see above). Throws on failure.
nlohmann::json runPoint(const PointSpec& point, const RunContext& context);

/// Computes (or finds in the cache) the point's reference only; returns a
/// description {"reference": ..., "cached": bool, "cache_dir": ..., "seconds": ...,
/// "stats": {...}} and, for Monte Carlo, mc_stderr_l2_lum / mc_stderr_l2_rgb.
nlohmann::json prepareReference(const PointSpec& point, const RunContext& context);

/// The error block of a summary (summary["error"]'s metrics: l1_lum ...
/// regions), the CLI's and the store's field names.
nlohmann::json errorMetricsJson(const reference::ErrorMetrics& metrics);

/// Same key the cache uses for the point's reference: scene label + kind +
/// settings description ("" when kind = none).
std::string referenceId(const PointSpec& point);

/// Build type baked in at compile time ("Release", "Debug", ...).
std::string buildType();
/// git describe of the source tree at configure time.
std::string codeVersion();
/// Host name of this machine.
std::string hostName();
/// Current UTC time, ISO 8601.
std::string isoDateUtc();

}  // namespace hrad::experiments
