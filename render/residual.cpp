// The residual of a radiosity solution; see residual.h.
#include "render/residual.h"

#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/safe_file.h"
#include "core/log.h"
#include "core/rng.h"
#include "core/timer.h"
#include "render/final_gather.h"
#include "scene/element.h"

namespace hrad::render {

ResidualSettings ResidualSettings::fromParams(const Params& params, const std::string& prefix) {
    Params::Scope scope(params, "transport residual");
    auto key = [&](const char* k) { return prefix + "." + k; };
    ResidualSettings s;
    s.points = int(params.getInt({key("points"), "transport residual: points per leaf"}, s.points,
                                 2, 1 << 16));
    s.gatherRays =
        int(params.getInt({key("gather_rays"), "transport residual: gather rays per point"},
                          s.gatherRays, 1, 1 << 20));
    s.shadowRays =
        int(params.getInt({key("shadow_rays"), "transport residual: shadow rays per gather sample"},
                          s.shadowRays, 1, 1 << 16));
    s.seed = uint64_t(params.getInt({key("seed"), "transport residual: seed of its rays"},
                                    int64_t(s.seed), 0, INT64_MAX));
    return s;
}

ResidualSummary computeResidual(const scene::Scene& scene, const transport::Visibility& visibility,
                                const scene::RadiosityField& field, const ResidualSettings& settings,
                                bool showProgress) {
    Timer timer;
    GatherSettings gs;
    gs.gatherRays = settings.gatherRays;
    gs.shadowRays = settings.shadowRays;
    gs.seed = settings.seed;
    Gatherer gatherer(scene, visibility, gs);
    size_t numEmitters = 0;
    for (const auto& p : scene.patches) numEmitters += p.isEmitter() ? 1 : 0;

    const size_t n = scene.patches.size();
    std::vector<std::vector<LeafResidual>> perPatch(n);
    ProgressBar bar("residual", n, showProgress);
    const int k = settings.points;
    const int strata = std::max(1, int(std::lround(std::sqrt(double(k)))));
    tbb::parallel_for(size_t(0), n, [&](size_t pi) {
        const scene::Patch& p = scene.patches[pi];
        auto& out = perPatch[pi];
        field.forEachLeaf(uint32_t(pi), [&](scene::ElementKey key, const RGB& b) {
            const scene::Domain d = scene::keyDomain(p.kind, key);
            LeafResidual leaf;
            leaf.patch = uint32_t(pi);
            leaf.key = key;
            leaf.area = scene::elementArea(p, d);
            leaf.B = b;
            Pcg32 rng(hashIds(settings.seed, pi, key));
            // Jacobian-weighted mean and its standard error over the points.
            RGB swx(0.0), swx2(0.0);
            double wsum = 0, w2sum = 0;
            for (int s = 0; s < k; ++s) {
                double a = rng.nextDouble(), c = rng.nextDouble();
                if (strata * strata == k) {
                    a = ((s % strata) + a) / strata;
                    c = ((s / strata) + c) / strata;
                }
                if (p.kind == scene::PatchKind::Triangle && a + c > 1) {
                    a = 1 - a;
                    c = 1 - c;
                }
                const double w = scene::elementJacobian(p, d, a, c);
                const Vec3 x = scene::elementPoint(p, d, a, c);
                const RGB g = gatherer.finalGather(field, uint32_t(pi), x, rng);
                swx += w * g;
                swx2 += w * g * g;
                wsum += w;
                w2sum += w * w;
            }
            if (wsum > 0) {
                leaf.gathered = swx / wsum;
                // Weighted variance of the points, then of their weighted mean.
                RGB var = glm::max(swx2 / wsum - leaf.gathered * leaf.gathered, RGB(0.0));
                leaf.stdError = glm::sqrt(var * (w2sum / (wsum * wsum)));
            }
            out.push_back(leaf);
        });
        bar.add(1);
    });
    bar.done();

    ResidualSummary r;
    double noise = 0;
    for (auto& v : perPatch)
        for (auto& leaf : v) {
            const scene::Patch& p = scene.patches[leaf.patch];
            if (!p.isEmitter()) {
                r.reflectedSolution += leaf.area * luminance(leaf.B - p.emission);
                r.reflectedGathered += leaf.area * luminance(leaf.gathered - p.emission);
                r.l1 += leaf.area * std::fabs(luminance(leaf.B - leaf.gathered));
                noise += leaf.area * luminance(leaf.stdError) * std::sqrt(2.0 / 3.14159265358979323846);
            }
            r.leaves.push_back(leaf);
        }
    if (r.reflectedGathered > 0) {
        r.l1 /= r.reflectedGathered;
        r.l1Noise = noise / r.reflectedGathered;
    }
    r.rays = uint64_t(r.leaves.size()) * uint64_t(k) *
             (uint64_t(settings.gatherRays) + uint64_t(settings.shadowRays) * numEmitters);
    r.seconds = timer.seconds();
    return r;
}

void writeResidualCsv(const std::string& path, const ResidualSummary& r) {
    std::ostringstream o;
    o << "patch,key,area,B_r,B_g,B_b,gathered_r,gathered_g,gathered_b,se_r,se_g,se_b\n";
    o.precision(9);
    for (const auto& l : r.leaves)
        o << l.patch << ',' << l.key << ',' << l.area << ',' << l.B.r << ',' << l.B.g << ','
          << l.B.b << ',' << l.gathered.r << ',' << l.gathered.g << ',' << l.gathered.b << ','
          << l.stdError.r << ',' << l.stdError.g << ',' << l.stdError.b << '\n';
    writeFileSafely(path, o.str());
}

}  // namespace hrad::render
