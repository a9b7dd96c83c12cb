// Which patches light can reach at all.
//
// A patch receives light only along directions whose first hit is the front
// of a patch that itself has light (one-sided surfaces emit and reflect from
// their front only; a two-sided surface is two patches, each seen from its
// own side). A patch none of whose directions leads, hit after hit, back to
// an emitter stays exactly at its emission: the inside of a closed box in a
// lit room, a cavity between wall slabs, a face pressed against the back of
// a wall. The solver gives such patches light only by mistake: a link into a
// cluster spreads its irradiance over every surface of the cluster that
// faces the sender, seen or not (cluster/transfer.h), and the light then
// goes round inside the cavity (graz.mgf: papers/README.md, "Where graz's
// remaining leak comes from").
//
// reachablePatches casts `rays` cosine-weighted rays from uniform points on
// each patch's front (a ray is a sample of the patch's incoming
// radiance directions) and records the patches whose fronts they hit
// first: light can go from each of those to the patch. The patches light
// can reach are then the emitters and everything reachable from them along
// these edges (a breadth-first search). Rays only prove reachability: a
// patch whose only view of lit surfaces is a fraction x of its
// cosine-weighted hemisphere is missed with probability (1 - x)^rays
// (64 rays: 3.7 % at x = 5 %, 0.12 % at x = 10 %), and is then treated as
// dark. The light it would have had is at most about x of a fully exposed
// patch's, but such patches are many where geometry is cluttered: on
// graz.mgf one-sided 64 rays left out 3,762 patches and 4,096 rays 1,466.
// The rays are cast in stages (4 per patch, then up to 16, 64, ...): after
// each stage only the patches not yet reached cast the next stage's rays, the
// same rays of the same random stream. The reachable set is exactly that of
// `rays` rays from every patch (a patch on a path from an emitter is either
// reached early or casts all its rays, the path's edge among them), for a
// fraction of the rays where most patches see lit surfaces.
// With `retryRays`, every patch the first rays leave unconnected casts that
// many more (only those patches: one is then missed with probability
// (1 - x)^(rays + retryRays)) and the search runs again (hr.reach_retry_rays,
// off by default, hr/solver.h). The solver (hr.reach_rays) leaves unreachable non-emitting patches
// out of the transport: no cluster holds them and no link reaches them.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/params.h"
#include "scene/loader.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::transport {

struct Reachability {
    /// reachable[p] = 1 when light can reach patch p (emitters included).
    std::vector<uint8_t> reachable;
    uint32_t unreachable = 0;  ///< patches with reachable[p] == 0
    /// With `darkEdges` asked for: (s, r) for every unreachable patch r and
    /// each patch s whose front r's rays hit first (s is then unreachable
    /// too): where light would go if s had any.
    std::vector<std::pair<uint32_t, uint32_t>> darkEdges;
    uint64_t rays = 0;         ///< rays cast
    double seconds = 0.0;
};

/// `rays` rays per patch (> 0), seeded by `seed` and the patch index (the
/// same result for any thread count); every patch still unreachable after
/// them casts `retryRays` more and the search is repeated. `firstStage`:
/// the rays per patch of the first stage (>= rays: one stage, every patch
/// casts all its rays; the reachable set is the same either way).
Reachability reachablePatches(const scene::Scene& scene, const Visibility& vis, int rays,
                              uint64_t seed = 1, int retryRays = 0, int firstStage = 4,
                              bool darkEdges = false);

/// The reachability pass above as the loader's scene::ReachabilityFn: its own
/// Visibility of the scene it is given, `seed`, staged rays.
scene::ReachabilityFn lightPathsFn(uint64_t seed = 1);

/// scene::loadScene handed the reachability pass above (its own Visibility
/// of the scene it is given, seed 1), which split_intersections =
/// "unreachable" uses to keep only the cuts that separate pieces light
/// reaches from pieces it does not (scene/loader.h). Every command that
/// solves, references or renders a scene loads it through this; it also
/// hands in discontinuity meshing (transport/discontinuity.h, mesh.*).
scene::Scene loadScene(const std::string& spec, const Params& params = {});

}  // namespace hrad::transport
