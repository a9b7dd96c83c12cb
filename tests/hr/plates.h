// Shared by the tests that solve the built-in plates against a reference
// (sender_total_test, eps_power_test): the relative L2 of region means on
// one patch (their settings: test::plateSettings, tests/hr/settings.h).
#pragma once

#include <cmath>

#include "scene/element.h"
#include "scene/field.h"
#include "scene/scene.h"

namespace hrad::test {

/// Relative L2 (red channel) of a's region means against ref's over the
/// 32 x 32 level-5 regions of patch `patch`, and (when asked) the ratio of
/// their sums.
inline double regionL2(const scene::Scene& s, const scene::RadiosityField& a,
                       const scene::RadiosityField& ref, uint32_t patch, double* ratio = nullptr) {
    const int level = 5, n = 1 << level;
    double num = 0, den = 0, sa = 0, sr = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            auto k = scene::keyAt(s.patches[patch].kind, (i + 0.5) / n, (j + 0.5) / n, level);
            double x = a.average(patch, k).x, r = ref.average(patch, k).x;
            num += (x - r) * (x - r);
            den += r * r;
            sa += x;
            sr += r;
        }
    if (ratio) *ratio = sa / sr;
    return std::sqrt(num / den);
}

}  // namespace hrad::test
