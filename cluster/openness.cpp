#include "cluster/openness.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <limits>

#include "core/rng.h"
#include "core/timer.h"

namespace hrad::cluster {

namespace {
// The fixed points on a patch: stratified on the unit square, mapped by
// ClusterTree::pointOnPatch.
constexpr double kStrata[SurfaceOpenness::kPoints][2] = {
    {0.25, 0.25}, {0.75, 0.25}, {0.25, 0.75}, {0.75, 0.75}};
// Distances are coded on a log scale from kNear times the scene's diagonal
// (code 0, and everything nearer) to the diagonal (code 254).
constexpr double kNear = 1e-5;
}  // namespace

uint8_t SurfaceOpenness::quantise(bool hit, double t) const {
    if (!hit) return 255;
    if (!(t > distance_[1])) return 0;
    // The step from the logarithm, then rounded down against the table, so
    // that a coded distance never exceeds the true one.
    int q = int(std::floor((std::log(t / distance_[254]) / -std::log(kNear) + 1.0) * 254.0));
    q = std::clamp(q, 1, 254);
    while (q > 1 && t < distance_[q]) --q;
    while (q < 254 && t >= distance_[q + 1]) ++q;
    return uint8_t(q);
}

SurfaceOpenness::SurfaceOpenness(const scene::Scene& scene, const ClusterTree& tree,
                                 const transport::Visibility& visibility, uint64_t seed)
    : scene_(&scene), tree_(&tree) {
    Timer timer;
    scene::Bounds3 box = scene.bounds();
    const double diagonal = std::max(1e-30, glm::length(box.hi - box.lo));
    distance_[0] = 0.0;
    for (int q = 1; q < 255; ++q) distance_[q] = diagonal * std::pow(kNear, 1.0 - q / 254.0);
    distance_[255] = std::numeric_limits<double>::infinity();
    const size_t stride = size_t(kBins) * kPoints;
    dist_.assign(scene.patches.size() * stride, 0);
    const uint32_t n = tree.orderSize();
    std::atomic<uint64_t> rays{0};
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 64), [&](const auto& range) {
        uint64_t local = 0;
        for (uint32_t i = range.begin(); i != range.end(); ++i) {
            const uint32_t patch = tree.patchAt(i);
            const View v = view(patch);
            uint8_t* row = dist_.data() + size_t(patch) * stride;
            Pcg32 rng(reseed(hashIds(patch, 0x6f70656eULL), seed));
            for (int k = 0; k < kBins; ++k) {
                const int band = k / kSectors, sector = k % kSectors;
                for (int j = 0; j < kPoints; ++j) {
                    // A direction uniform (in solid angle) within the bin.
                    double z = (band + rng.nextDouble()) / kBands;
                    double phi = (sector + rng.nextDouble()) * (2.0 * kPi / kSectors);
                    double sz = std::sqrt(std::max(0.0, 1.0 - z * z));
                    Vec3 d = sz * (std::cos(phi) * v.t + std::sin(phi) * v.b) + z * v.n;
                    transport::RayHit hit =
                        visibility.intersect(v.x[j], d, 0.0, distance_[254], patch);
                    ++local;
                    row[k * kPoints + j] = quantise(hit.hit, hit.t);
                }
            }
        }
        rays += local;
    });
    rays_ = rays.load();
    seconds_ = timer.seconds();
}

SurfaceOpenness::View SurfaceOpenness::view(uint32_t patch) const {
    const scene::Patch& P = scene_->patches[patch];
    View v;
    v.n = P.normal;
    Vec3 e = P.v[1] - P.v[0];
    e -= glm::dot(e, v.n) * v.n;
    double len = glm::length(e);
    if (!(len > 0)) {
        // A degenerate edge: any tangent orthogonal to n.
        e = std::abs(v.n.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
        e -= glm::dot(e, v.n) * v.n;
        len = glm::length(e);
    }
    v.t = e / len;
    v.b = glm::cross(v.n, v.t);
    for (int j = 0; j < kPoints; ++j)
        v.x[j] = tree_->pointOnPatch(patch, kStrata[j][0], kStrata[j][1]);
    v.dist = dist_.data() + size_t(patch) * kBins * kPoints;
    return v;
}

}  // namespace hrad::cluster
