// Error of a radiosity solution against a reference (DESIGN.md "Reference
// solves and error").
//
// Both fields live on the same root patches and subdivide the same parametric
// domains, so the average of the solution over each reference element (a
// "region") is computed exactly from the solution's leaves
// (RadiosityField::average), never resampled. For every region k with area
// A_k, solution average S_k and reference value R_k:
//
//   L1   = sum_k A_k |S_k - R_k|   / sum_k A_k |R_k|
//   L2   = sqrt(sum_k A_k |S_k - R_k|^2) / sqrt(sum_k A_k |R_k|^2)
//   Linf = max_k |S_k - R_k| / max_k |R_k|
//
// once with |.| the absolute value of luminance (core/types.h, Rec. 709
// weights) and once with |.| the Euclidean norm of the RGB triple. A ratio
// whose denominator is 0 is 0 when its numerator is 0 too, else +infinity.
// The all-region numbers above are dominated by the emitters, whose radiosity
// is E by construction: they flatter a solver. What the solver computes is
// the reflected part B - E, so two more families are reported (luminance):
//
//   reflected     L1 = sum_k A_k |S_k - R_k| / sum_k A_k |R_k - E_k|, L2 the
//                 same with squares: the error relative to the reflected
//                 radiosity (the numerator is unchanged, S - R = (S-E) - (R-E));
//   non-emitter   L1, L2 over the regions of patches with E = 0 only, and the
//                 mean ratio sum_k A_k S_k / sum_k A_k R_k over them: the
//                 systematic darkness (< 1) or brightness of the lit surfaces;
//   dark          the fraction of the solution's reflected power,
//                 sum A (S - E) (luminance), that lies on regions whose reference
//                 has no reflected light at all (R = E exactly: a Monte Carlo
//                 reference scores exactly 0 where no path reaches a light, so
//                 this is light leaking into closed cavities), and their number;
//   by material   per material, the reflected power sum A (S - E) of the
//                 solution and sum A (R - E) of the reference (luminance):
//                 where a solve's light is missing or extra.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "scene/field.h"

namespace hrad::reference {

/// Reflected power (luminance, sum A (B - E)) of one material's regions.
struct MaterialPower {
    uint32_t material = 0;
    double area = 0.0;
    double solution = 0.0, reference = 0.0;
};

struct ErrorMetrics {
    double l1Lum = 0.0, l2Lum = 0.0, linfLum = 0.0;
    double l1Rgb = 0.0, l2Rgb = 0.0, linfRgb = 0.0;
    double l1ReflLum = 0.0, l2ReflLum = 0.0;        ///< relative to the reflected part R - E
    double l1NonEmitLum = 0.0, l2NonEmitLum = 0.0;  ///< over non-emitting regions only
    double meanRatioNonEmit = 1.0;                  ///< sum A S / sum A R over non-emitting regions
    double darkReflectedFraction = 0.0;  ///< reflected power on regions the reference has dark
    size_t darkRegions = 0;              ///< regions whose reference reflected radiosity is 0
    size_t regions = 0;                  ///< reference elements compared
    double refArea = 0.0;                ///< sum of their areas
    /// Per material with any area, largest |solution - reference| first.
    std::vector<MaterialPower> byMaterial;

    std::string describe() const;
};

/// Error of `solution` against `reference`. Both must be defined on scenes
/// with the same patches (checked: same patch count; the scenes are normally
/// the same object). Throws hrad::Error when they differ.
ErrorMetrics computeError(const scene::RadiosityField& solution,
                          const scene::UniformField& reference);

/// The non-emitter luminance errors with regions merged per original patch
/// (Scene::sourcePatch: the pieces of a patch cut by discontinuity meshing,
/// and every reference element on them, count as one region of the summed
/// area), so solves of one scene meshed differently compare on the same
/// regions. With `stdError` (a Monte Carlo reference, one per region), the
/// same norm of the merged regions' standard errors
/// (sigma^2 = sum A_k^2 sigma_k^2 / (sum A_k)^2): the error floor.
struct SourcePatchError {
    double l1NonEmitLum = 0.0, l2NonEmitLum = 0.0;
    double stderrL2NonEmitLum = 0.0;
    size_t patches = 0;  ///< source patches compared (emitters included)
};
SourcePatchError computeSourcePatchError(const scene::RadiosityField& solution,
                                         const scene::UniformField& reference,
                                         const std::vector<RGB>& stdError = {});

/// The solution's exact averages over the reference's regions, as a field on
/// the reference's mesh (S_k above for every k): what the metrics compare,
/// e.g. for a per-region error map. Same checks as computeError.
std::unique_ptr<scene::UniformField> averageOnRegions(const scene::RadiosityField& solution,
                                                      const scene::UniformField& reference);

/// Writes one CSV row per region (the S_k and R_k the metrics compare), so a
/// researcher can find where an error comes from: region, patch, element
/// (its index within the patch), material, area, the patch's emission E
/// (RGB), the solution's average S (RGB), the reference R (RGB) and, when
/// `stdError` has one entry per region (a Monte Carlo reference), R's
/// standard error (RGB; empty columns otherwise). Same checks as
/// computeError; throws hrad::Error when the file cannot be written.
void writeRegionsCsv(const std::string& path, const scene::RadiosityField& solution,
                     const scene::UniformField& reference, const std::vector<RGB>& stdError);

}  // namespace hrad::reference
