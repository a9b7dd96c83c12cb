// Light links: the hierarchical solve's links from non-area lights
// (scene/lights/light.h) to surface elements (issue 63 item 1).
//
// A light is a sender whose output never changes, so a light link from light
// l to element j carries one number, j's mean irradiance from l,
//   Ebar_lj = sum_k w_k E_l(x_k)      (quadrature points x_k on j, weights w_k
//                                      by area; E_l with visibility,
//                                      transport/light_irradiance.h)
// and gather adds rho_j Ebar_lj to j's gathered radiosity every iteration
// (Hierarchy::lightGathered; B = E + rho H, Cohen & Wallace 1993 eq. 2.54).
//
// Refinement asks the solve's oracle, as for a surface link (Hanrahan,
// Salzman & Aupperle 1991): the link is presented as a transfer from a
// sender of radiosity S (the largest irradiance over j's points, max
// channel) with the kernel f(x) = E_l(x) / S, so F = Ebar / S and the point
// kernel's range [Fmin, Fmax] = [min_k, max_k] E_l(x_k) / S (Fmin = 0 where
// the shadow rays disagree: a shadow boundary crosses j). The error oracle
// then refines while A_j rho_j (Emax - Emin) > eps P (oracles/error_oracle.h),
// bfa while A_j rho_j Ebar > eps P. The sender cannot subdivide, so a refined
// link is replaced by links to j's four children. Links start at every root
// patch facing the light; each eps stage re-judges them (the light's output
// does not change, so nothing else triggers a re-judgement). The refinement
// checks (hr/checks/) are not run on light links.
//
// Clusters (hr.light_clusters, off by default): with a cluster tree the
// links start at the root cluster instead of every root patch. A light link
// to a cluster carries the mean irradiance of the surfaces below it,
// weighted by area and reflectance per channel (Ebar_c = sum A_q rho_qc E_qc
// / sum A_q rho_qc, one point per patch: its centroid), and hands it to
// every surface below alike, as an isotropic cluster receives (Sillion
// 1995): each root patch q gathers rho_q Ebar, so the reflected power is
// the points' sum. A cluster is opened wherever a patch below it faces away
// from the light or a shadow ray of its points is blocked: handed alike,
// that light would fill shadows (measured: papers/notes/
// 2026-12-03-lights-importance.md, accepting such clusters by the error
// oracle's eps P alone washed out a grid's shadows, residual L2 3.6 % ->
// 19.5 %). Elsewhere the judgement is a surface link's with the cluster's
// area and mean reflectance and the range over its patches' points (the
// cosine's variation). A refined cluster link is
// replaced by links to its children (sub-clusters or root patches, those of
// zero reflectance left out); below a root patch links refine as above.
//
// Points: transport::elementMeanPoints with m = 3: quads 3 x 3 midpoints weighted by the map's
// Jacobian; triangles the centroids of the 9 congruent sub-triangles (equal
// weights). Both are midpoint rules: O(h^2) error in the element mean.
// Environments use k x k stratified cosine directions per point
// (hr.light_strata, default 8) with one direction pattern per element, so
// their noise is the same at every point and does not look like variation.
#pragma once

#include <cstdint>
#include <vector>

#include "core/params.h"
#include "core/types.h"
#include "hr/hierarchy.h"
#include "oracles/oracle.h"
#include "transport/visibility.h"

namespace hrad::hr {

struct LightLinkSettings {
    int strata = 8;         ///< hr.light_strata
    bool clusters = false;  ///< hr.light_clusters
    static LightLinkSettings fromParams(const Params& p);
};

class LightLinks {
  public:
    LightLinks(const scene::Scene& scene, const transport::Visibility& vis,
               LightLinkSettings settings)
        : scene_(&scene), vis_(&vis), s_(settings) {}

    /// Judges every light link with `oracle` (making the initial links on
    /// the first call), subdivides receivers it refines and links their
    /// children, then sets h.lightGathered. Returns the links refined.
    uint64_t refine(Hierarchy& h, const oracles::Oracle& oracle, double epsPower,
                    double emittedRadiosity);

    uint64_t numLinks() const { return links_.size(); }
    uint64_t rays() const { return rays_; }
    uint64_t memoryBytes() const { return links_.capacity() * sizeof(LightLink); }
    /// The mean irradiance (all lights) each element received, indexed by node.
    std::vector<RGB> irradiance(const Hierarchy& h) const;

  private:
    struct LightLink {
        uint32_t receiver;
        uint32_t light;
        float E[3];  ///< Ebar per channel
        float pad = 0.f;
    };
    struct Judged {
        RGB mean{0.0};
        oracles::Decision decision = oracles::Decision::Accept;
    };
    /// What judge() asks the oracle, from the points of a surface element
    /// or of a cluster's patches.
    struct Points {
        RGB mean{0.0};
        double lo = 1e300, hi = 0.0, hiFree = 0.0, meanFree = 0.0;
        int shadowed = 0, reached = 0, n = 0;
    };
    Judged judge(const Hierarchy& h, const LightLink& l, const oracles::Oracle& oracle,
                 double epsPower, double emittedRadiosity, uint64_t& rays) const;
    Points surfacePoints(const Hierarchy& h, const LightLink& l, uint64_t& rays) const;
    Points clusterPoints(const Hierarchy& h, const LightLink& l, uint64_t& rays) const;
    /// Calls f(root patch) for every root patch a link's light reaches.
    template <class F>
    void forEachPatch(const Hierarchy& h, uint32_t receiver, F&& f) const;
    void linkChildren(Hierarchy& h, const LightLink& l, std::vector<LightLink>& next) const;
    void initialLinks(const Hierarchy& h);
    void apply(Hierarchy& h) const;

    const scene::Scene* scene_;
    const transport::Visibility* vis_;
    LightLinkSettings s_;
    std::vector<LightLink> links_;
    bool made_ = false;
    uint64_t rays_ = 0;
};

}  // namespace hrad::hr
