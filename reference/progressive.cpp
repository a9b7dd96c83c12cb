// Progressive refinement radiosity with substructuring; see progressive.h.
#include "reference/progressive.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "core/error.h"
#include "core/log.h"
#include "core/timer.h"
#include "reference/fullmatrix.h"
#include "scene/element.h"

namespace hrad::reference {

namespace {

double l1(const RGB& c) { return std::fabs(c.r) + std::fabs(c.g) + std::fabs(c.b); }

/// Element ids seed the engine's visibility samples: unique per (root patch,
/// key) and identical for a patch as shooter and as receiver element. Keys
/// stay below 2^30 (level <= 14, checked in fromParams/solve).
constexpr int kIdKeyBits = 30;
constexpr int kMaxElementLevel = 14;
uint64_t elementId(uint32_t patch, scene::ElementKey key) {
    return (uint64_t(patch) << kIdKeyBits) | key;
}

struct Hit {
    scene::ElementKey key;  ///< finest element key the cell landed in
    double dF;              ///< its delta form factor (weighted by the shooter point)
};

struct Leaf {
    scene::ElementKey key;
    RGB B;
    double area;
};

/// A shooter: one uniform-level element of a root patch, with its receiver
/// elements (the leaves of its quadtree).
struct PatchState {
    uint32_t root;
    scene::ElementKey key;
    double area;
    RGB unshot;
    std::vector<Leaf> leaves;
};

}  // namespace

ProgressiveSettings::ProgressiveSettings() : ff(fullMatrixFormFactorDefaults()) {}

ProgressiveSettings ProgressiveSettings::fromParams(const Params& params, const std::string& prefix) {
    Params::Scope scope(params, "progressive solver");
    ProgressiveSettings s;
    auto key = [&](const char* k) { return prefix.empty() ? std::string(k) : prefix + "." + k; };
    s.level = int(params.getInt({key("level"), "progressive: uniform level of patches"}, s.level, 0,
                                kMaxElementLevel));
    s.maxArea = params.getDouble(
        {key("max_area"), "progressive: subdivide patches above this area (0: by level only)"},
        s.maxArea, 0.0, 1e300);
    s.maxLevel = int(params.getInt({key("max_level"), "progressive: level at most with max_area"},
                                   s.maxLevel, 0, kMaxElementLevel));
    s.maxSubdivision = int(params.getInt(
        {key("max_subdivision"), "progressive: substructuring depth of elements below patches"},
        s.maxSubdivision, 0, kMaxElementLevel));
    s.subdivideThreshold =
        params.getDouble({key("subdivide_threshold"),
                          "progressive: radiosity gradient past which an element is subdivided"},
                         s.subdivideThreshold, 0.0, 1e300, true);
    s.tolerance = params.getDouble(
        {key("tolerance"), "progressive: unshot power fraction at which shooting stops"},
        s.tolerance, 0.0, 1.0);
    s.maxShots = params.getInt({key("max_shots"), "progressive: shots at most"}, s.maxShots, 1,
                               int64_t(1) << 40);
    s.ambient = params.getBool(
        {key("ambient"), "progressive: add the ambient term of unshot power (Cohen et al. 1988)"},
        s.ambient);
    s.historyEvery = int(
        params.getInt({key("history_every"), "progressive: a history row every this many shots"},
                      s.historyEvery, 1, 1000000000));
    s.regather = params.getBool(
        {key("regather"), "progressive: a final gather pass over all elements"}, s.regather);
    s.ff = transport::FormFactorSettings::fromParams(params, key("ff"), fullMatrixFormFactorDefaults());
    s.hemicube = transport::HemicubeSettings::fromParams(params, key("ff"));
    const int deepest = (s.maxArea > 0 ? s.maxLevel : s.level) + s.maxSubdivision;
    if (deepest > kMaxElementLevel)
        throwInputError(params.where(key("max_subdivision")),
                        "{} = {} puts elements at level {} (patch level {} + {}); the deepest is {}",
                        key("max_subdivision"), s.maxSubdivision, deepest, deepest - s.maxSubdivision,
                        s.maxSubdivision, kMaxElementLevel);
    return s;
}

std::string ProgressiveSettings::describe() const {
    return fmt::format(
        "level={} max_area={} max_level={} max_subdivision={} subdivide_threshold={} "
        "regather={} tolerance={} max_shots={} ambient={} history_every={} ff={{{}{}}}",
        level, maxArea, maxLevel, maxSubdivision, subdivideThreshold, regather, tolerance, maxShots, ambient,
        historyEvery, ff.describe(), hemicube.describe());
}

ProgressiveResult solveProgressive(const scene::Scene& scene, const transport::Visibility& visibility,
                                   const ProgressiveSettings& settings, bool showProgress,
                                   const ProgressiveHook& hook, const StopPoll& stop) {
    Timer timer;
    std::vector<uint8_t> levels =
        scene::uniformLevels(scene, settings.level, settings.maxArea, settings.maxLevel);
    for (uint8_t l : levels)
        if (int(l) + settings.maxSubdivision > kMaxElementLevel)
            throw Error(fmt::format("progressive: patch level {} + max_subdivision {} exceeds the "
                                    "deepest element level {}",
                                    int(l), settings.maxSubdivision, kMaxElementLevel));

    // ---- patches and their initial elements (the patches themselves) ----
    std::vector<PatchState> P;
    for (uint32_t r = 0; r < scene.patches.size(); ++r) {
        const scene::Patch& patch = scene.patches[r];
        scene::ElementKey first = scene::ElementKey(1) << (2 * levels[r]);
        for (scene::ElementKey k = first; k < 2 * first; ++k) {
            double a = scene::elementArea(patch, scene::keyDomain(patch.kind, k));
            P.push_back(PatchState{r, k, a, patch.emission, {Leaf{k, patch.emission, a}}});
        }
    }
    const size_t n = P.size();
    HRAD_CHECK_MSG(n < size_t(UINT32_MAX), "{} patches exceed 32-bit indices", n);

    // Scales: emitted power, mean reflectance, B_scale (see the header).
    double areaSum = 0, emitted = 0;
    RGB rhoArea(0.0);
    for (const PatchState& p : P) {
        areaSum += p.area;
        emitted += p.area * l1(p.unshot);
        rhoArea += p.area * scene.patches[p.root].rho;
    }
    const RGB rhoAvg = areaSum > 0 ? rhoArea / areaSum : RGB(0.0);
    const RGB ambientR = RGB(1.0) / (RGB(1.0) - rhoAvg);  // 1 / (1 - rho_avg), rho < 1
    const double rhoMean = (rhoAvg.r + rhoAvg.g + rhoAvg.b) / 3.0;
    const double bScale = areaSum > 0 ? emitted / 3.0 / (areaSum * (1.0 - rhoMean)) : 0.0;
    const double gradLimit = settings.subdivideThreshold * bScale;

    transport::FormFactorEngine engine(scene, &visibility, settings.ff);
    auto refOf = [&](uint32_t root, scene::ElementKey k) {
        const scene::Patch& patch = scene.patches[root];
        return transport::ElementRef{root, scene::keyDomain(patch.kind, k), elementId(root, k)};
    };

    ProgressiveResult res;
    res.patches = n;
    std::vector<uint64_t> ffCount(n, 0), rayCount(n, 0);
    // Hemicube shooting state (settings.hemicube.enabled).
    std::optional<transport::Hemicube> cube;
    if (settings.hemicube.enabled) cube.emplace(settings.hemicube.res);
    std::vector<size_t> rootOffset(scene.patches.size() + 1, 0);
    for (uint32_t r = 0; r < scene.patches.size(); ++r)
        rootOffset[r + 1] = rootOffset[r] + (size_t(1) << (2 * levels[r]));
    std::vector<std::vector<Hit>> hits(cube ? n : 0);
    std::vector<Vec3> hcPoints;
    std::vector<double> hcWeights;
    // Radiosity each patch has shot so far (for regathering new elements).
    std::vector<RGB> shotSoFar(n, RGB(0.0));

    auto unshotPower = [&] {
        double s = 0;
        for (const PatchState& p : P) s += p.area * l1(p.unshot);
        return s;
    };
    auto bytesNow = [&] {
        uint64_t b = n * sizeof(PatchState);
        for (const PatchState& p : P) b += p.leaves.capacity() * sizeof(Leaf);
        return b;
    };
    auto numLeaves = [&] {
        size_t c = 0;
        for (const PatchState& p : P) c += p.leaves.size();
        return c;
    };
    auto displayField = [&] {
        RGB ambient(0.0);
        if (settings.ambient && areaSum > 0) {
            RGB u(0.0);
            for (const PatchState& p : P) u += p.area * p.unshot;
            ambient = ambientR * u / areaSum;
        }
        std::vector<std::vector<scene::LeafField::Leaf>> leaves(scene.patches.size());
        for (const PatchState& p : P) {
            const RGB rho = scene.patches[p.root].rho;
            for (const Leaf& l : p.leaves) leaves[p.root].push_back({l.key, l.B + rho * ambient});
        }
        return std::make_unique<scene::LeafField>(scene, std::move(leaves));
    };
    auto record = [&](int64_t shots, uint32_t shooter, double unshot) {
        ProgressiveRecord rec;
        rec.shots = shots;
        rec.shooter = shooter;
        rec.unshotFraction = emitted > 0 ? unshot / emitted : 0.0;
        rec.elements = numLeaves();
        for (size_t i = 0; i < n; ++i) {
            rec.formFactors += ffCount[i];
            rec.rays += rayCount[i];
        }
        rec.seconds = timer.seconds();
        rec.bytes = bytesNow();
        if (hook) hook(*displayField(), rec);
        res.history.push_back(rec);
    };

    // One shot from patch j: every other patch i gathers onto its elements.
    auto shoot = [&](uint32_t j) {
        const PatchState& S = P[j];
        const transport::ElementRef sRef = refOf(S.root, S.key);
        const RGB U = S.unshot;
        // Hemicube shooting (Cohen et al. 1988): hemicubes on the
        // shooter give F_{j -> x} per cell; each hit is binned under the
        // finest element key it may need, per receiving patch.
        if (cube) {
            for (auto& h : hits) h.clear();
            const scene::Patch& sp = scene.patches[S.root];
            transport::hemicubePoints(sp, sRef.dom, settings.hemicube.points, hcPoints, hcWeights);
            for (size_t k = 0; k < hcPoints.size(); ++k)
                rayCount[j] += cube->project(
                    visibility, scene, hcPoints[k], sp.normal, S.root,
                    [&](uint32_t q, const Vec3& x, double dF) {
                        const scene::Patch& pq = scene.patches[q];
                        Vec2 uv = glm::clamp(scene::patchInverse(pq, x), Vec2(0.0), Vec2(1.0));
                        if (pq.kind == scene::PatchKind::Triangle && uv.x + uv.y > 1) uv /= uv.x + uv.y;
                        scene::ElementKey fine =
                            scene::keyAt(pq.kind, uv.x, uv.y, levels[q] + settings.maxSubdivision);
                        size_t i = rootOffset[q] +
                                   size_t((fine >> (2 * settings.maxSubdivision)) -
                                          (scene::ElementKey(1) << (2 * levels[q])));
                        hits[i].push_back({fine, hcWeights[k] * dF});
                    });
        }
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4), [&](const tbb::blocked_range<size_t>& rg) {
            std::vector<Leaf> out;
            for (size_t i = rg.begin(); i != rg.end(); ++i) {
                PatchState& R = P[i];
                // Planar root patches: elements of the same root exchange nothing.
                if (R.root == S.root) continue;
                if (cube ? hits[i].empty() : !engine.facing(refOf(R.root, R.key), sRef)) continue;
                const RGB rhoU = scene.patches[R.root].rho * U;
                const int patchLevel = scene::keyLevel(R.key);
                const scene::Patch& patch = scene.patches[R.root];
                auto shotAt = [&](scene::ElementKey k) {
                    if (cube) {
                        // F_kj = F_jk A_j / A_k (reciprocity), F_jk the cells landing on k.
                        double fjk = 0;
                        for (const Hit& h : hits[i])
                            if (scene::keyContains(k, h.key)) fjk += h.dF;
                        double ak = scene::elementArea(patch, scene::keyDomain(patch.kind, k));
                        return rhoU * (fjk * S.area / ak);
                    }
                    transport::FormFactorResult f = engine.compute(refOf(R.root, k), sRef);
                    ++ffCount[i];
                    rayCount[i] += f.rays;
                    return rhoU * f.F;
                };
                RGB gathered(0.0);  // sum_e A_e dB_e
                // distribute(): adds dB to element `key` (old radiosity B),
                // substructuring it where the shot's gradient is steep.
                // Radiosity of a new element before this shot: regathered from
                // every patch's shot radiosity (exact), or its parent's.
                auto before = [&](scene::ElementKey key, const RGB& parentB) {
                    if (!settings.regather) return parentB;
                    RGB g(0.0);
                    const transport::ElementRef eRef = refOf(R.root, key);
                    for (size_t k = 0; k < n; ++k) {
                        if (P[k].root == R.root || l1(shotSoFar[k]) == 0) continue;
                        const transport::ElementRef kRef = refOf(P[k].root, P[k].key);
                        if (!engine.facing(eRef, kRef)) continue;
                        transport::FormFactorResult f = engine.compute(eRef, kRef);
                        ++ffCount[i];
                        rayCount[i] += f.rays;
                        g += f.F * shotSoFar[k];
                    }
                    return patch.emission + patch.rho * g;
                };
                auto distribute = [&](auto&& self, scene::ElementKey key, const RGB& B, bool fresh,
                                      double area, const RGB* known) -> void {
                    RGB dB;
                    if (scene::keyLevel(key) - patchLevel < settings.maxSubdivision) {
                        RGB dc[4];
                        double ac[4];
                        double grad = 0;
                        for (int c = 0; c < 4; ++c) {
                            scene::ElementKey ck = scene::childKey(key, c);
                            dc[c] = shotAt(ck);
                            ac[c] = scene::elementArea(patch, scene::keyDomain(patch.kind, ck));
                            for (int d = 0; d < c; ++d) grad = std::max(grad, l1(dc[c] - dc[d]));
                        }
                        if (grad > gradLimit) {
                            for (int c = 0; c < 4; ++c)
                                self(self, scene::childKey(key, c), B, true, ac[c], &dc[c]);
                            return;
                        }
                        dB = RGB(0.0);
                        double asum = 0;
                        for (int c = 0; c < 4; ++c) {
                            dB += ac[c] * dc[c];
                            asum += ac[c];
                        }
                        dB /= asum;
                    } else {
                        dB = known ? *known : shotAt(key);
                    }
                    out.push_back(Leaf{key, (fresh ? before(key, B) : B) + dB, area});
                    gathered += area * dB;
                };
                out.clear();
                for (const Leaf& l : R.leaves) distribute(distribute, l.key, l.B, false, l.area, nullptr);
                R.leaves.swap(out);
                R.leaves.shrink_to_fit();
                R.unshot += gathered / R.area;
            }
        });
        shotSoFar[j] += U;
        P[j].unshot = RGB(0.0);
    };

    // ---- shooting loop ----
    ProgressBar bar(fmt::format("progressive ({} patches)", n), 1000, showProgress);
    const double stopAt = settings.tolerance * emitted;
    double unshot = unshotPower();
    uint64_t barPos = 0;
    uint32_t last = 0;
    record(0, 0, unshot);
    while (unshot > stopAt && res.shots < settings.maxShots) {
        // A signal: the shots so far are the result, marked interrupted.
        if (stop()) {
            spdlog::warn("signal {} received after {} shots: the progressive solution so far is the "
                         "result, marked interrupted", interruptSignal(), res.shots);
            res.interrupted = true;
            break;
        }
        uint32_t j = 0;
        double best = -1;
        for (size_t i = 0; i < n; ++i) {
            double p = P[i].area * l1(P[i].unshot);
            if (p > best) {
                best = p;
                j = uint32_t(i);
            }
        }
        if (!(best > 0)) break;
        shoot(j);
        last = j;
        ++res.shots;
        unshot = unshotPower();
        if (res.shots % settings.historyEvery == 0) record(res.shots, j, unshot);
        if (emitted > 0 && settings.tolerance > 0 && unshot > 0) {
            // Progress on a log scale from 1 (nothing shot) to the tolerance.
            double f = std::log(unshot / emitted) / std::log(settings.tolerance);
            uint64_t pos = uint64_t(std::clamp(f, 0.0, 1.0) * 1000);
            if (pos > barPos) {
                bar.add(pos - barPos);
                barPos = pos;
            }
        }
    }
    bar.done();
    if (res.history.back().shots != res.shots) record(res.shots, last, unshot);

    res.unshotFraction = emitted > 0 ? unshot / emitted : 0.0;
    res.converged = unshot <= stopAt;
    res.elements = numLeaves();
    for (size_t i = 0; i < n; ++i) {
        res.formFactors += ffCount[i];
        res.rays += rayCount[i];
    }
    res.bytes = bytesNow();
    res.field = displayField();
    res.seconds = timer.seconds();
    return res;
}

}  // namespace hrad::reference
