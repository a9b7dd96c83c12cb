#include "reference/metrics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/error.h"
#include "core/safe_file.h"

namespace hrad::reference {

namespace {
double ratio(double num, double den) {
    if (den > 0) return num / den;
    return num > 0 ? std::numeric_limits<double>::infinity() : 0.0;
}
}  // namespace

std::string ErrorMetrics::describe() const {
    return fmt::format(
        "reflected L1={:.4g} L2={:.4g}  non-emitters L1={:.4g} L2={:.4g} mean ratio={:.4f}  "
        "all regions: lum L1={:.4g} L2={:.4g} Linf={:.4g}  rgb L1={:.4g} L2={:.4g} "
        "Linf={:.4g}  ({} regions, area {:.4g}; {} dark in the reference, holding {:.3g} of the "
        "reflected power)",
        l1ReflLum, l2ReflLum, l1NonEmitLum, l2NonEmitLum, meanRatioNonEmit, l1Lum, l2Lum, linfLum,
        l1Rgb, l2Rgb, linfRgb, regions, refArea, darkRegions, darkReflectedFraction);
}

ErrorMetrics computeError(const scene::RadiosityField& solution,
                          const scene::UniformField& reference) {
    const scene::Scene& scene = reference.scene();
    if (solution.scene().patches.size() != scene.patches.size())
        throw Error(fmt::format("error metric: solution has {} patches, reference {}",
                                solution.scene().patches.size(), scene.patches.size()));
    // Sums in a fixed order (patches, then elements): deterministic.
    double dLum1 = 0, rLum1 = 0, dLum2 = 0, rLum2 = 0, dLumMax = 0, rLumMax = 0;
    double dRgb1 = 0, rRgb1 = 0, dRgb2 = 0, rRgb2 = 0, dRgbMax = 0, rRgbMax = 0;
    double reflLum1 = 0, reflLum2 = 0;                                // reflected denominators
    double neD1 = 0, neR1 = 0, neD2 = 0, neR2 = 0, neS = 0, neR = 0;  // non-emitters
    double darkPower = 0, reflectedPower = 0;  // solution's reflected power, on dark regions
    ErrorMetrics m;
    std::vector<MaterialPower> byMaterial(scene.materials.size());
    for (uint32_t i = 0; i < byMaterial.size(); ++i) byMaterial[i].material = i;
    for (uint32_t p = 0; p < scene.patches.size(); ++p) {
        const double E = luminance(scene.patches[p].emission);
        const bool emitter = maxComponent(scene.patches[p].emission) > 0.0;
        for (size_t l = 0; l < reference.count(p); ++l) {
            size_t idx = reference.offset(p) + l;
            double A = reference.area(idx);
            const RGB& R = reference.value(idx);
            RGB S = solution.average(p, reference.key(p, l));
            double dl = std::fabs(luminance(S) - luminance(R)), rl = std::fabs(luminance(R));
            double dc = glm::length(S - R), rc = glm::length(R);
            dLum1 += A * dl;
            rLum1 += A * rl;
            dLum2 += A * dl * dl;
            rLum2 += A * rl * rl;
            dLumMax = std::max(dLumMax, dl);
            rLumMax = std::max(rLumMax, rl);
            const RGB Erg = scene.patches[p].emission;
            double sr = luminance(S) - E;
            reflectedPower += A * sr;
            if (scene.patches[p].material < byMaterial.size()) {
                MaterialPower& mp = byMaterial[scene.patches[p].material];
                mp.area += A;
                mp.solution += A * sr;
                mp.reference += A * (luminance(R) - E);
            }
            if (maxComponent(glm::abs(R - Erg)) == 0.0) {
                darkPower += A * sr;
                ++m.darkRegions;
            }
            double rr = std::fabs(luminance(R) - E);
            reflLum1 += A * rr;
            reflLum2 += A * rr * rr;
            if (!emitter) {
                neD1 += A * dl;
                neR1 += A * rl;
                neD2 += A * dl * dl;
                neR2 += A * rl * rl;
                neS += A * luminance(S);
                neR += A * luminance(R);
            }
            dRgb1 += A * dc;
            rRgb1 += A * rc;
            dRgb2 += A * dc * dc;
            rRgb2 += A * rc * rc;
            dRgbMax = std::max(dRgbMax, dc);
            rRgbMax = std::max(rRgbMax, rc);
            ++m.regions;
            m.refArea += A;
        }
    }
    m.l1Lum = ratio(dLum1, rLum1);
    m.l2Lum = ratio(std::sqrt(dLum2), std::sqrt(rLum2));
    m.linfLum = ratio(dLumMax, rLumMax);
    m.l1ReflLum = ratio(dLum1, reflLum1);
    m.l2ReflLum = ratio(std::sqrt(dLum2), std::sqrt(reflLum2));
    m.l1NonEmitLum = ratio(neD1, neR1);
    m.l2NonEmitLum = ratio(std::sqrt(neD2), std::sqrt(neR2));
    m.meanRatioNonEmit = neR > 0 ? neS / neR : 1.0;
    m.darkReflectedFraction = reflectedPower > 0 ? darkPower / reflectedPower : 0.0;
    for (const MaterialPower& mp : byMaterial)
        if (mp.area > 0) m.byMaterial.push_back(mp);
    std::stable_sort(m.byMaterial.begin(), m.byMaterial.end(),
                     [](const MaterialPower& a, const MaterialPower& b) {
                         return std::fabs(a.solution - a.reference) >
                                std::fabs(b.solution - b.reference);
                     });
    m.l1Rgb = ratio(dRgb1, rRgb1);
    m.l2Rgb = ratio(std::sqrt(dRgb2), std::sqrt(rRgb2));
    m.linfRgb = ratio(dRgbMax, rRgbMax);
    return m;
}

SourcePatchError computeSourcePatchError(const scene::RadiosityField& solution,
                                         const scene::UniformField& reference,
                                         const std::vector<RGB>& stdError) {
    const scene::Scene& scene = reference.scene();
    if (solution.scene().patches.size() != scene.patches.size())
        throw Error(fmt::format("error metric: solution has {} patches, reference {}",
                                solution.scene().patches.size(), scene.patches.size()));
    const size_t n = scene.numSourcePatches();
    std::vector<double> area(n, 0.0), sSum(n, 0.0), rSum(n, 0.0), var(n, 0.0);
    std::vector<uint8_t> emitter(n, 0);
    const bool mc = stdError.size() == reference.numElements();
    for (uint32_t p = 0; p < scene.patches.size(); ++p) {
        const uint32_t q = scene.sourceOf(p);
        if (scene.patches[p].isEmitter()) emitter[q] = 1;
        for (size_t l = 0; l < reference.count(p); ++l) {
            const size_t idx = reference.offset(p) + l;
            const double A = reference.area(idx);
            area[q] += A;
            sSum[q] += A * luminance(solution.average(p, reference.key(p, l)));
            rSum[q] += A * luminance(reference.value(idx));
            if (mc) var[q] += A * A * luminance(stdError[idx]) * luminance(stdError[idx]);
        }
    }
    // Sums in source-patch order: deterministic.
    double d1 = 0, r1 = 0, d2 = 0, r2 = 0, e2 = 0;
    SourcePatchError out;
    for (size_t q = 0; q < n; ++q) {
        if (area[q] <= 0) continue;
        ++out.patches;
        if (emitter[q]) continue;
        const double S = sSum[q] / area[q], R = rSum[q] / area[q];
        d1 += area[q] * std::fabs(S - R);
        r1 += area[q] * std::fabs(R);
        d2 += area[q] * (S - R) * (S - R);
        r2 += area[q] * R * R;
        e2 += area[q] * var[q] / (area[q] * area[q]);
    }
    out.l1NonEmitLum = ratio(d1, r1);
    out.l2NonEmitLum = ratio(std::sqrt(d2), std::sqrt(r2));
    out.stderrL2NonEmitLum = ratio(std::sqrt(e2), std::sqrt(r2));
    return out;
}

std::unique_ptr<scene::UniformField> averageOnRegions(const scene::RadiosityField& solution,
                                                      const scene::UniformField& reference) {
    const scene::Scene& scene = reference.scene();
    if (solution.scene().patches.size() != scene.patches.size())
        throw Error(fmt::format("error metric: solution has {} patches, reference {}",
                                solution.scene().patches.size(), scene.patches.size()));
    std::vector<uint8_t> levels(scene.patches.size());
    for (uint32_t p = 0; p < scene.patches.size(); ++p) levels[p] = uint8_t(reference.level(p));
    auto out = std::make_unique<scene::UniformField>(scene, std::move(levels));
    for (uint32_t p = 0; p < scene.patches.size(); ++p)
        for (size_t l = 0; l < reference.count(p); ++l)
            out->value(reference.offset(p) + l) = solution.average(p, reference.key(p, l));
    return out;
}

void writeRegionsCsv(const std::string& path, const scene::RadiosityField& solution,
                     const scene::UniformField& reference, const std::vector<RGB>& stdError) {
    std::unique_ptr<scene::UniformField> avg = averageOnRegions(solution, reference);
    const scene::Scene& scene = reference.scene();
    const bool withError = stdError.size() == reference.numElements();
    std::string f;
    f.append(
        "region,patch,element,material,area,E_r,E_g,E_b,S_r,S_g,S_b,R_r,R_g,R_b,"
        "R_stderr_r,R_stderr_g,R_stderr_b\n");
    for (uint32_t p = 0; p < scene.patches.size(); ++p) {
        const scene::Patch& patch = scene.patches[p];
        const std::string& material =
            patch.material < scene.materials.size() ? scene.materials[patch.material].name : "";
        // Material names are written as given; one with a comma or a quote is
        // quoted (RFC 4180).
        std::string quoted = material;
        if (material.find_first_of(",\"\n") != std::string::npos) {
            quoted.assign(1, '"');
            for (char ch : material) {
                if (ch == '"') quoted.push_back('"');
                quoted.push_back(ch);
            }
            quoted.push_back('"');
        }
        for (size_t l = 0; l < reference.count(p); ++l) {
            const size_t k = reference.offset(p) + l;
            const RGB& S = avg->value(k);
            const RGB& R = reference.value(k);
            std::string row = fmt::format(
                "{},{},{},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}",
                k, p, l, quoted, reference.area(k), patch.emission.r, patch.emission.g,
                patch.emission.b, S.r, S.g, S.b, R.r, R.g, R.b);
            if (withError)
                row += fmt::format(",{:.9g},{:.9g},{:.9g}\n", stdError[k].r, stdError[k].g,
                                   stdError[k].b);
            else
                row += ",,,\n";
            f += row;
        }
    }
    writeFileSafely(path, f);
}

}  // namespace hrad::reference
