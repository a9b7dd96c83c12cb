// Which patches light can reach at all; see reachability.h.
#include "transport/reachability.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

#include "core/rng.h"
#include "core/sampling.h"
#include "core/timer.h"
#include "transport/discontinuity.h"

namespace hrad::transport {

Reachability reachablePatches(const scene::Scene& scene, const Visibility& vis, int rays,
                              uint64_t seed, int retryRays, int firstStage, bool darkEdges) {
    Timer timer;
    const uint32_t n = uint32_t(scene.patches.size());
    const int m = std::max(1, rays);
    // sources[p]: the distinct patches whose fronts p's rays hit first (light
    // can go from each of them to p).
    std::vector<std::vector<uint32_t>> sources(n);
    // Casts rays [first, first + count) of patch p's random stream `stream`
    // and merges the patches whose fronts they hit into sources[p].
    auto cast = [&](uint32_t p, int first, int count, uint64_t stream,
                    std::vector<uint32_t>& hits) {
        const scene::Patch& P = scene.patches[p];
        Pcg32 rng(seed, stream);
        for (int i = 0; i < 4 * first; ++i) rng.nextDouble();  // four draws per ray
        hits.assign(sources[p].begin(), sources[p].end());
        for (int i = 0; i < count; ++i) {
            double u = rng.nextDouble(), v = rng.nextDouble();
            if (P.kind == scene::PatchKind::Triangle && u + v > 1) {
                u = 1 - u;
                v = 1 - v;
            }
            Vec3 x = P.point(u, v);
            Vec3 dir = cosineDirection(P.normal, rng.nextDouble(), rng.nextDouble());
            RayHit h = vis.intersect(x, dir, 0.0, 1e300, p);
            // The ray must arrive at the hit patch's front: a one-sided
            // patch seen from behind sends nothing this way.
            if (h.hit && glm::dot(scene.patches[h.patch].normal, dir) < 0) hits.push_back(h.patch);
        }
        std::sort(hits.begin(), hits.end());
        hits.erase(std::unique(hits.begin(), hits.end()), hits.end());
        sources[p].assign(hits.begin(), hits.end());
    };
    Reachability out;
    // Breadth-first search from the emitters along the edges source ->
    // receiver (as offsets: counting sort by source).
    auto search = [&]() {
        std::vector<uint64_t> offset(size_t(n) + 1, 0);
        for (uint32_t p = 0; p < n; ++p)
            for (uint32_t s : sources[p]) ++offset[s + 1];
        for (uint32_t s = 0; s < n; ++s) offset[s + 1] += offset[s];
        std::vector<uint32_t> receivers(offset[n]);
        {
            std::vector<uint64_t> fill(offset.begin(), offset.end() - 1);
            for (uint32_t p = 0; p < n; ++p)
                for (uint32_t s : sources[p]) receivers[fill[s]++] = p;
        }
        out.reachable.assign(n, 0);
        std::vector<uint32_t> queue;
        for (uint32_t p = 0; p < n; ++p)
            if (scene.patches[p].isEmitter()) {
                out.reachable[p] = 1;
                queue.push_back(p);
            }
        for (size_t head = 0; head < queue.size(); ++head) {
            const uint32_t s = queue[head];
            for (uint64_t i = offset[s]; i < offset[s + 1]; ++i) {
                const uint32_t r = receivers[i];
                if (!out.reachable[r]) {
                    out.reachable[r] = 1;
                    queue.push_back(r);
                }
            }
        }
        out.unreachable = n - uint32_t(queue.size());
    };
    // The `m` rays in stages of firstStage, 4 times that, ... rays per patch:
    // after each stage only the patches the search has not reached cast the
    // rest of the next stage's rays (the same rays of the same stream). The
    // reachable set is exactly that of m rays from every patch: along any
    // path of edges from an emitter, each patch is either reached at an
    // earlier stage or, not reached, has cast all m rays and so has the edge
    // of the path into it. In a room most patches are reached after the
    // first stage.
    {
        std::vector<uint32_t> todo(n);
        for (uint32_t p = 0; p < n; ++p) todo[p] = p;
        int done = 0;
        for (int stage = std::min(m, std::max(1, firstStage));; stage = std::min(m, 4 * stage)) {
            const int first = done, count = stage - done;
            tbb::parallel_for(tbb::blocked_range<size_t>(0, todo.size(), 64),
                              [&](const auto& range) {
                                  std::vector<uint32_t> hits;
                                  for (size_t i = range.begin(); i != range.end(); ++i)
                                      cast(todo[i], first, count, 2 * uint64_t(todo[i]) + 1, hits);
                              });
            out.rays += uint64_t(todo.size()) * uint64_t(count);
            done = stage;
            search();
            if (done == m || out.unreachable == 0) break;
            todo.clear();
            for (uint32_t p = 0; p < n; ++p)
                if (!out.reachable[p]) todo.push_back(p);
        }
    }
    if (retryRays > 0 && out.unreachable > 0) {
        // A second look from every patch the first rays did not connect:
        // `retryRays` more rays each, then the search again.
        std::vector<uint32_t> retry;
        for (uint32_t p = 0; p < n; ++p)
            if (!out.reachable[p]) retry.push_back(p);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, retry.size(), 16), [&](const auto& range) {
            std::vector<uint32_t> hits;
            for (size_t i = range.begin(); i != range.end(); ++i)
                cast(retry[i], 0, retryRays, 2 * uint64_t(retry[i]) + 2, hits);
        });
        out.rays += uint64_t(retry.size()) * uint64_t(retryRays);
        search();
    }
    if (darkEdges)
        for (uint32_t p = 0; p < n; ++p)
            if (!out.reachable[p])
                for (uint32_t s : sources[p]) out.darkEdges.emplace_back(s, p);
    out.seconds = timer.seconds();
    return out;
}

scene::ReachabilityFn lightPathsFn(uint64_t seed) {
    return [seed](const scene::Scene& s, int rays) {
        Visibility vis(s);
        Reachability r = reachablePatches(s, vis, rays, seed, 0, 4, /*darkEdges=*/true);
        return scene::LightPaths{std::move(r.reachable), std::move(r.darkEdges)};
    };
}

scene::Scene loadScene(const std::string& spec, const Params& params) {
    return scene::loadScene(spec, params, lightPathsFn(), discontinuityMeshFn());
}

}  // namespace hrad::transport
