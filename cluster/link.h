// Links that touch a cluster: when the point approximation is valid, the
// unoccluded transfer it gives, and the visibility estimated with rays
// (DESIGN.md "Clustering"; Smits, Arvo & Greenberg 1994, "A clustering
// algorithm for radiosity in complex environments"; Sillion 1995, "A unified
// hierarchical algorithm for global illumination with scattering volumes and
// object clusters").
//
// This is the physics of a cluster link; hr/ (the refinement driver) asks for
// a link between two of its nodes, described by a plain LinkEnd, and stores
// what comes back. cluster/ does not see the hierarchy.
//
// Transfer (cluster/transfer.h): K = A_s g_s(u) g_r(-u) / (pi r^2) between
// the two nodes' centroids, times a visibility fraction from rays between
// points on the surfaces of both nodes. Four choices keep these links from
// losing light (measured per link against Monte Carlo integrals of the same
// links: papers/README.md, "Clustering accuracy"):
//   - the oracle judges a link from a cluster with the largest radiosity of
//     the root patches below it (LinkEnd::maxB), not the mean, so clusters
//     holding an emitter are opened (hr/solver.cpp linkEstimate);
//   - the visibility the oracle sees (judged) and the one in K (carried)
//     come from independent rays: with one estimate, links whose estimate
//     came out low were accepted and kept it, the others refined, a
//     selection bias of O(1/n) that no eps removes;
//   - a link whose judged rays are all blocked is kept (uncertain) and
//     judged with the unoccluded transfer times the 95 % bound on the
//     visibility, 1 - 0.05^(1/n), instead of being dropped, so links through
//     small openings (doorways) are refined where they matter;
//   - ray end points are drawn with the density the transfer gives the
//     surfaces (receiving cluster: A_k cos_k; sending cluster: A_k B_k cos_k)
//     and the unblocked fraction is weighted by the kernel cos cos / r^2 of
//     each ray over that density, so a luminaire's housing does not weigh
//     like its emitting face, nor far or non-facing pairs like the near,
//     facing pairs that carry the light.
// Validity: a link is valid in the point approximation when the bounding
// spheres are apart, and, between two clusters, when the centroids are more
// than `separation` times the sum of the radii apart: at shorter distances
// the directions between the two clusters' surfaces spread by up to 90
// degrees around the centroid direction along which both projected areas and
// the receiver's cosines are taken; Smits et al. 1994 and Sillion 1995 accept
// cluster links only for well-separated clusters. A cluster holding a single
// surface is that surface and is opened at once.
//
// Face clusters (cluster.faces, cluster/tree.h; Willmott, Heckbert & Garland
// 1999). A face cluster whose normal cone and planarity are within
// cluster.face_cone and cluster.face_planarity (ClusterTree::planarFace) is
// a nearly flat piece of surface, not a volume: the directions from it to
// another node do not spread around the centroid direction the way a
// volume's surfaces do, its projected area is (for coplanar surfaces
// exactly) its area times the cosine, and its receiver cosines are those of
// its surfaces. Links with a planar face cluster at one end are therefore
// not held to `separation`: between two face clusters, or a face cluster
// and a surface element, the link is valid once the centroids are more than
// `face_separation` times the sum of the radii apart (1 would be spheres
// apart, as for a surface element, but the point transfer then gains light:
// office:3 +4.8 % green at 1, +0.4 % at 1.5, -0.4 % at 2, against the
// unclustered solve; bench/results/face_clusters.md); a face cluster and a
// volume cluster keep `surface_separation`. Whether the link is then refined is the oracle's
// decision, from the same transfer, visibility and upper bound as any
// cluster link (the upper bound A_s / (pi gap^2) holds for every pair of
// points). Two coplanar flat ends (surface elements, or face clusters whose
// cone and planarity are zero: ClusterTree::flatFace) exchange no light: such
// a link is dropped without rays (this drops the self-link of a flat face
// cluster instead of opening it down to its patches). A link with a planar
// face cluster at one end whose centroids do not face each other (point
// transfer 0: a planar face cluster's projected area is exactly 0 behind its
// plane, where a volume cluster's is rarely so) is opened rather than dropped
// when the other end's bounding sphere reaches in front of each flat end's
// plane: the parts that do face exchange light (straddles()).
//
// Sending clusters that carry no light yet (cluster.defer_dark). A link's
// visibility is estimated with ray end points drawn by the light its sending
// cluster's surfaces carry (above), and kept for as long as the link lives.
// In the first judging pass only the emitters carry light, so nearly every
// link from a cluster used to be made with end points drawn by area and
// cosine alone, over surfaces that would stay dark (the undersides of
// desks, the backs of chairs) as much as over those the light reaches, and
// the ones it reaches are the ones that see the rest of the room: the
// visibility came out low. Measured on classroom (bfa 1e-3, oriented,
// reflected power against the unclustered solve): the first bounce lost
// 1.6 %, the second 7.5 %. A link from a cluster whose root patches all
// have B = 0 is therefore made without rays (ClusterLink::deferred; it
// carries nothing, as its sender sends nothing) and computed in the first
// judging pass after the cluster carries light (every element that turns
// from dark to lit triggers one, hr/solver.h "Lazy refinement"). The cost
// is no more rays than before: each link is computed once.
// The end points are then drawn by A_k (B_k + rho_k a) (cluster.ambient):
// the light of the bounces still to come, spread evenly, is the ambient
// term of Cohen, Chen, Wallace & Greenberg 1988, "A progressive refinement
// approach to fast radiosity image generation": a = (P_e rho / (1 - rho) -
// reflected power now) / total area, rho the area-weighted mean reflectance
// (capped at 0.99), per channel. Without it the links made after the first
// bounce are drawn by direct light alone, which is more concentrated than
// the final radiosities: office:3 gained 0.9 % against the unclustered
// solve, 0.4 % with it (papers/README.md, "Clustering accuracy").
//
// Receiving clusters (cluster.handover). An oriented receiving cluster hands
// a link's light to each surface below it by its cosine towards the sender
// and, by default, by how open it is towards the sender within the cluster
// (cluster/openness.h): a surface hidden inside the cluster (a seat under
// its desk) no longer takes the light of the surfaces that hide it. The
// link's K is divided by the cluster's openness W (Hierarchy::handOverNewLinks,
// once per link), so the power it delivers is unchanged and only where it
// lands moves.
//
// Near cluster pairs (cluster.near = sample). Two clusters whose spheres are
// apart but closer than `separation` need not be opened: their transfer is
// estimated by Monte Carlo integration of the kernel with visibility,
//     P = A_r E_x[ integral over the sender of B(y) cos_x+ cos_y+ V(x, y)
//                  / (pi |x - y|^2) dA_y ],
// x drawn uniformly by area on the receiver's surfaces and y on the sender's
// by A_k m_k (m_k = max_c (B_k + rho_k a), the density above), each pair
// weighted by c_k / m_k (c_k the mean channel of B_k + rho_k a) so that the
// estimate is the power with the sender's radiosities, whatever the distance
// (no direction is assumed). It is stored as the K that the gather turns
// back into that power: K = P / (A_r b), b the mean channel of what the
// gather multiplies K by (the sender's radiosity towards the receiver,
// LinkEnd::sent), and for an oriented receiving cluster divided also by
// E[cos+(n_x, u)] (u towards the sender's centroid; the push hands each
// surface K cos_k+(u)), computed over the receiver's patches apart from the
// estimate's points (receiverCosine: from the same points K would be a
// ratio estimate, biased at small n). A sender that carries no light, or a
// sender surface element, is drawn by area (c = m). Two independent estimates
// again (judged, carried); the judged one's error bound (two standard
// errors) travels with the link (Link::uncertainty), and refinement opens
// the link when the power it may carry wrongly exceeds the oracle's eps
// (as a power fraction, oracles::Oracle::receiverCheckEps: ff's F_eps / 100)
// times the emitted power. Estimates the model cannot use are opened
// instead (sampledLink: light arriving on receiver surfaces that face away
// from the sender's centroid, a transfer above 1, an error bound above the
// estimate).
// Off by default: on Lost Empire the sampled pairs carry 1.3 % less light
// than the opened ones, and no reference says which is right
// (papers/README.md, "Near cluster pairs").
//
// Stand-ins (cluster.stand_in). A solve stopped early by hr.max_links,
// memory.budget_mb or hr.max_seconds keeps the links it was about to open
// (Link::kOpen); without a transfer they carry nothing, and on a capped
// cluttered scene that is most of the light: the bathroom capped at 3 M
// links left 2.9 M of its 5.3 M links unopened and came out a quarter dark
// against Monte Carlo (bench/results/large_scenes.md). Each such link gets a
// stand-in instead, a Monte Carlo estimate of its transfer that needs no
// direction and no separation, so it holds for overlapping spheres and a
// cluster's self-link alike. Receiver points x are drawn by area over r's
// surfaces. Sender surfaces k are drawn with probability
// q_k: A_k / A_s, or, for a sending cluster whose surfaces carry light,
// half of that plus half of A_k m_k / M (m_k the largest channel of the
// surface's B_k + rho_k a, M = sum A_k m_k; a defensive mixture, Hesterberg
// 1995), so that light on a few small surfaces of s is drawn often and the
// density never falls below half of uniform where s is dark.
//
// When the bounding spheres are apart, a point y by area on the drawn
// surface counts the kernel g = cos_x+ cos_y+ / (pi d^2) with visibility
// over its density q_k / A_k (bounded there by A_k / (q_k gap^2)). When
// they overlap, g has no bound where the two ends meet and g over an area
// density no finite variance. A cosine-distributed direction from x finds
// a surface point y with density g(y) per unit area and, counted 1 where it
// finds s, is bounded, but finds a small sender by chance only: a 4 cm lamp
// strip, form factor 0.024 from its housing's end cap, is found by 0.4 of
// 32 rays. Each x then takes two directions: a cosine-distributed one
// (clipped to s's bounding sphere; its nearest hit counts if it belongs to
// s and faces the ray), and one uniform over the solid angle Omega_k(x) of
// the drawn surface (Arvo 1995, core/sampling.h; density q_k cos_y /
// (d^2 Omega_k) per unit area; a point by area where Omega_k is below
// 1e-7 sr). Each y found counts g / (g + p(y)), p the second draw's density
// at y: the balance heuristic of multiple importance sampling (Veach &
// Guibas 1995). Each count lies in [0, 1], so the variance stays finite,
// and their mean is the transfer. stand_in_rays / 2 points, two rays each,
// keep the ray count (measurements: papers/README.md, "The stand-in
// estimate").
// The samples that found s are kept, by
// root patch: the gather sums weight times that patch's current radiosity,
// so the stand-in follows where on s the light is as the solve goes on
// (fixed to the radiosities at the stop it was 5 % too bright on classroom
// capped at 75 k links, papers/README.md). The receiving cluster hands the
// light to its surfaces by area (each takes the link's irradiance, as an
// isotropic cluster does): where the pair is too close for any direction
// the split among the receiver's surfaces is not modelled, but the light is
// not lost. The estimate's error bound (two standard errors) travels with
// the link like a sampled near link's. Where the spheres are apart and the
// receiver is an oriented cluster, its surfaces take the light by their
// cosine towards the sender's centroid instead, as a point-approximation
// link's (K and the samples divided by the receiver's mean cosine,
// receiverCosine), unless more than 5 % of the estimate arrived on surfaces
// facing away from that centroid.
//
// Judged stand-ins (cluster.near = stand_in). The same estimate made when a
// pair is first found too close for the point approximation (near or
// overlapping spheres, a cluster's self-link), before anything is opened:
// the oracle judges it like any link (by a second, independent estimate of
// the transfer and the sender's largest radiosity), and it stays when the
// oracle accepts it, that estimate's error bound times its power is within
// eps of the emitted power (as a sampled near link's), and, when its
// receiving cluster takes the light by area, all its power is within eps
// too (it may all land on the wrong surfaces). Otherwise the pair is opened
// as before. Everything that decides whether a stand-in stays, and which
// checks it faces, comes from the independent estimate: the hand-over (by
// cosine, or by area with the check of all its power), and the judged
// transfer per unit receiver area (K of a cosine hand-over is divided by
// the receiver's mean cosine; the judged transfer is not, the oracle weighs
// it by the whole receiver area). A stand-in whose carried estimate found
// nothing stays a stand-in with K = 0 and faces the same checks. Decided by
// the carried estimate, the stand-ins kept would be those whose estimate
// came out low, and the solve darker than the truth; the sum of the kept
// stand-ins' power then matches Monte Carlo (tests/hr/stand_in_audit_test).
// A judged estimate that found nothing is judged by its 95 % upper bound
// (for overlapping spheres, zero successes in all n directions, also when
// none entered the sender's sphere). The link count of cluttered scenes is
// then set by eps where the error allows, not by the separation rule.
//
// Small pairs are opened (cluster.near_open_pairs, the default). Opening a
// pair of n and m surfaces costs at most about n m surface links, so where
// n m is small the exact links are cheap, and the stand-in's failure mode
// is worst there: a pair of few surfaces whose light arrives on a small part
// of the receiver (a lamp and its housing's end caps on classroom: 72 and
// 73 surfaces) is missed by a few sample points and, by area, lit alike on
// both shells. Pairs with at most near_open_pairs (receiver surface, sender
// surface) pairs are therefore opened as before, and only larger ones, where
// forced opening multiplies, are judged (the bathroom, 380 k triangles, with
// every near pair opened: rounds of 75-125 M candidate links, unfinished
// after 47 minutes; bench/results/large_scenes.md).
// With 8,192: classroom and corridor as accurate as opening everything,
// graz more accurate with a tenth of the links, Lost Empire 0.6 % darker at
// eps 1e-3 (equal at 1e-4) for a third of the CPU, and the bathroom solves
// (papers/README.md, "Small near pairs opened, large ones judged").
//
// Settings (Params keys):
//   cluster.vis_rays    int     8    visibility rays per estimate for links that
//                                     touch a cluster (two independent estimates)
//   cluster.separation  double  1.5  cluster-cluster links need a centroid distance
//                                     above this times the sum of the bounding radii
//                                     for the point approximation
//   cluster.surface_separation  double  1  the same for links between a surface
//                                     element and a cluster (1: bounding spheres apart).
//                                     Classroom loses 6.8 % of its reflected light with
//                                     clustering at 1 and 3.7 % at 3, for 2.1x the links
//                                     (papers/README.md, "Classroom")
//   cluster.near        string  "stand_in"  near cluster pairs (spheres apart, closer
//                                     than `separation`): open (always opened) | sample
//                                     (Monte Carlo transfer, above; experimental) |
//                                     stand_in (a judged stand-in, above "Judged
//                                     stand-ins", unless near_open_pairs opens it)
//   cluster.near_overlapping  bool  true  stand_in: overlapping pairs and self-links
//                                     too (false: always opened; by area a stand-in
//                                     lights every surface of its receiver alike, both
//                                     shells of classroom's lamp housings, which
//                                     near_open_pairs opens; papers/README.md "Where
//                                     the classroom's stand-in error lives")
//   cluster.near_open_pairs  int  8192  stand_in: pairs whose two ends have at most
//                                     this many (receiver surface, sender surface) pairs
//                                     are opened, not judged (above); 0: every near pair
//                                     is judged
//   cluster.near_rays   int     32   rays per estimate of a sampled near link (two
//                                     estimates per link)
//   cluster.defer_dark  bool    true  links from clusters that carry no light are
//                                     computed when they first do (above)
//   cluster.ambient     bool    true  sending clusters' points drawn by B_k + rho_k a
//                                     (the ambient term, above)
//   cluster.handover    string  "visible"  visible | cosine: an oriented receiving cluster
//                                     hands each link's light to its surfaces by cosine and
//                                     openness towards the sender within the cluster
//                                     (cluster/openness.h; K divided by the cluster's
//                                     openness, Hierarchy::handOverNewLinks), or by
//                                     cosine alone
//   cluster.stand_in    bool    true  links left unopened when refinement stops early
//                                     get a stand-in transfer (above); false: they carry nothing
//   cluster.stand_in_rays  int  128  point pairs (rays) per stand-in (judged and carried
//                                     estimates each). Each kept stand-in's error is held
//                                     within eps alone, so the errors of thousands add up:
//                                     at 32, Lost Empire's reflected power varied by 2.0 %
//                                     (one standard deviation) between ray seeds (hr.seed),
//                                     0.3 % at 128 and at 256; classroom's non-emitter L2
//                                     against Monte Carlo 6.5 +- 0.4 % at 32, 6.0 +- 0.15 %
//                                     at 128, 5.9 % at 256 and 512 (bench/results/
//                                     large_scenes.md, "The solver's own noise, over seeds")
//   cluster.stand_in_handover  string  "area"  area | seen: a stand-in that no
//                                     direction hands over (overlapping spheres, or
//                                     too much light on surfaces facing away) lights
//                                     every surface of its receiving cluster alike, by
//                                     area, or each by what it sees of the sender
//                                     (point-to-polygon form factors times a shadow ray
//                                     per point and sender surface; needs
//                                     cluster.handover = visible;
//                                     Hierarchy::handOverStandIns). seen puts classroom's
//                                     lamp light on the housings' inner shells, not the
//                                     outer ones (papers/README.md, "Overlapping
//                                     stand-ins summed over surface pairs")
//   cluster.stand_in_pairs  int  0    overlapping stand-ins whose two ends have at most
//                                     this many (receiver surface, sender surface) pairs
//                                     are summed over every pair (standInBySurfaces:
//                                     exact point-to-polygon form factors at jittered
//                                     receiver points, shadow rays drawn by the kernel)
//                                     instead of sampled; 0: always sampled. Finds the
//                                     small bright senders that sampling misses (a lamp
//                                     strip seen by its housing's end caps), at up to
//                                     8 rays per pair
//   cluster.face_separation  double  1.5  the same for links whose ends are planar face
//                                     clusters or surface elements, at least one a face
//                                     cluster (cluster.faces; 1: bounding spheres apart)
//   cluster.face_kernel  string  "point"  point | disc: the transfer of those links is
//                                     the point transfer, or with pi r^2 + A_r + A_s in the
//                                     denominator (the disc-to-disc form factor of coaxial
//                                     parallel discs within 3 %); disc loses 3 % of the light
//                                     on office:3 at face_separation 1.5 and is not the default
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "cluster/transfer.h"
#include "cluster/tree.h"
#include "core/params.h"
#include "core/rng.h"
#include "core/types.h"
#include "scene/element.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::cluster {

/// One end of a link as the cluster transfer sees it: a cluster of the tree,
/// or a surface element (a parametric domain of a root patch).
struct LinkEnd {
    bool isCluster = false;
    uint32_t cluster = 0;  ///< tree index (clusters)
    uint32_t patch = 0;    ///< root patch (surface elements)
    scene::Domain domain;  ///< parametric domain (surface elements)
    Vec3 center{0.0};
    double radius = 0.0;
    double area = 0.0;
    uint64_t stableId = 0;  ///< seeds the link's rays (thread-independent results)
    /// A cluster whose only child is one surface: it is that surface.
    bool singleSurface = false;
    /// Largest radiosity (max channel) of the root patches below a cluster.
    double maxB = 0.0;
    /// A sending cluster: the mean channel of the radiosity the gather
    /// multiplies the link's K by (its radiosity towards the receiver); 0
    /// when not known. Sampled near links use it (sampledLink).
    double sent = 0.0;
};

/// Which side(s) must be opened for the point approximation to hold.
enum class Opening : uint8_t { None, Receiver, Sender, Both };

struct ClusterLinkSettings {
    int visRays = 8;
    double separation = 1.5;
    double surfaceSeparation = 1.0;
    bool sampleNear = false;
    /// cluster.near = stand_in: pairs that must be opened get a judged
    /// stand-in first (ClusterLinker::standInNear).
    bool standInNear = true;
    /// cluster.near_overlapping: with stand_in, also overlapping pairs and
    /// a cluster's self-link (not only spheres apart).
    bool nearOverlapping = true;
    /// cluster.near_open_pairs: with stand_in, near and overlapping pairs with
    /// at most this many (receiver surface, sender surface) pairs are opened,
    /// not judged (0: every such pair is judged).
    uint64_t nearOpenPairs = 8192;
    int nearRays = 32;
    bool deferDark = true;
    bool ambient = true;
    double faceSeparation = 1.5;
    bool faceDisc = false;
    /// cluster.handover: an oriented receiving cluster hands each link's light
    /// to its surfaces by cosine and openness (true) or by cosine alone.
    bool visibleHandover = true;
    /// cluster.stand_in: links left to be opened when refinement stops early
    /// get a sampled stand-in transfer (ClusterLinker::standIn) instead of none.
    bool standIn = true;
    int standInRays = 128;
    /// cluster.stand_in_handover: stand-ins no direction hands over give
    /// each surface a share by what it sees of the sender (true, `seen`) or
    /// by area (false, the default).
    bool standInSeen = false;
    /// cluster.stand_in_pairs: overlapping stand-ins whose receiver and
    /// sender have at most this many surface pairs are summed over every
    /// pair (ClusterLinker::standInBySurfaces) instead of sampled; 0: never.
    uint64_t standInPairs = 0;
    static ClusterLinkSettings fromParams(const Params& p);
    std::string describe() const;
};

/// What link() computed.
struct ClusterLink {
    double K = 0.0;                ///< unoccluded point transfer times the carried visibility
    double Fupper = 0.0;           ///< upper bound (all cosines 1, nearest sphere points)
    double judged = 1.0;           ///< independent visibility estimate for the oracle
    Opening open = Opening::None;  ///< not None: invalid, nothing computed
    bool partial = false;          ///< some, not all, judged rays blocked
    bool uncertain = false;        ///< all judged rays blocked
    uint32_t rays = 0;
    /// Near pair estimated by Monte Carlo (see above): `judgedF` is the judged
    /// estimate of the power per unit receiver area and unit sender radiosity
    /// (receiver factor included), `relativeError` twice its relative standard
    /// error, and `judged` the judged visibility fraction.
    bool sampled = false;
    /// The sender is a cluster that carries no light yet (cluster.defer_dark):
    /// nothing computed, no rays cast; link() again once it carries light.
    bool deferred = false;
    /// A stand-in (standIn()): the receiver takes the light by area, the
    /// sender sends its mean radiosity.
    bool standIn = false;
    /// A stand-in into an oriented cluster whose light its surfaces take by
    /// their cosine towards the sender's centroid (K and the samples divided
    /// by the receiver's mean cosine), not by area.
    bool byCosine = false;
    double judgedF = 0.0;
    double relativeError = 0.0;
};

class ClusterLinker {
  public:
    ClusterLinker(const scene::Scene& scene, const ClusterTree* tree, ClusterModel model,
                  const transport::Visibility* visibility, ClusterLinkSettings settings);

    /// Projected-area fraction of e towards unit direction d: cos for a
    /// surface, 1/4 for an isotropic cluster, projectedArea/A for an oriented one.
    double projectedFraction(const LinkEnd& e, const Vec3& d) const;

    /// Unoccluded point-approximation transfer from s to r (without the
    /// receiver's projected-area fraction for an oriented receiving cluster,
    /// which is applied per surface when pushing); 0 when they do not face.
    double kernel(const LinkEnd& r, const LinkEnd& s) const;

    /// Sides to open before the point approximation holds (None: valid).
    /// For two surface elements always None (not a cluster link).
    Opening opening(const LinkEnd& r, const LinkEnd& s) const;

    /// 95 % upper bound on the visibility of a link whose vis_rays judged
    /// rays were all blocked: 1 - 0.05^(1/n) (Clopper-Pearson, zero successes).
    double blockedVisibilityBound() const { return blockedVisibilityBound(s_.visRays); }
    /// The same for `rays` rays: 1 - 0.05^(1/rays) (surface links judge
    /// theirs with ff.vis_rays, hr/solver.h "Judged visibility").
    static double blockedVisibilityBound(int rays);

    /// The link from s to r (at least one a cluster). `rootB` holds the
    /// current radiosity of every root patch (indexed by patch): the sender's
    /// ray end points are drawn in proportion to it.
    ClusterLink link(const LinkEnd& r, const LinkEnd& s, std::span<const RGB> rootB) const;

    /// The stand-in transfer of a link that had to be opened when refinement
    /// stopped early (hr.max_links, memory.budget_mb, hr.max_seconds; see
    /// "Stand-ins" above): a Monte Carlo estimate of the transfer from s to
    /// r over both ends' surfaces with visibility, whatever their distance
    /// (overlapping spheres, a cluster's self-link). K is the transfer per
    /// unit receiver area with s at one radiosity (a mean form factor);
    /// for a sending cluster, `samples` receives the samples that found s
    /// (by root patch, merged), whose weights sum to K.
    /// With `judge`, judgedF, relativeError, `judged` and the partial and
    /// uncertain flags come from a second, independent estimate (the one
    /// refinement judges: cluster.near = stand_in), else from the same.
    ClusterLink standIn(const LinkEnd& r, const LinkEnd& s,
                        std::vector<StandInSample>* samples = nullptr, bool judge = false) const;

    /// cluster.near = stand_in: whether the pair (r, s), which the point
    /// approximation cannot take (opening() is not None, or r is s), gets a
    /// stand-in that the oracle judges before it is opened: at least one end
    /// a cluster, neither a single-surface cluster, and the spheres apart
    /// unless cluster.near_overlapping.
    bool standInNear(const LinkEnd& r, const LinkEnd& s) const;

    /// Prepares link() to draw a sending cluster's ray end points from the
    /// prefix sums of A_k max_c (B_k + rho_k a) over the tree's patch order
    /// (a the ambient term, cluster.ambient; computed here from rootB; then
    /// accepting with probability cos_k), instead of drawing by area and
    /// accepting with probability cos_k B_k / max B: the same density, but a
    /// cluster whose light is on a few of its surfaces (81 lamps among Lost
    /// Empire's 112 k quads) no longer spends up to 32 draws per end point.
    /// Call whenever rootB changes, before the link() calls that use it (not
    /// concurrently with them); without it link() draws the old way.
    void prepareSenders(std::span<const RGB> rootB);
    /// The ambient radiosity per unit reflectance of the last prepareSenders
    /// (cluster.ambient; 0 when off).
    const RGB& ambient() const { return ambient_; }

    ClusterModel model() const { return model_; }
    const ClusterLinkSettings& settings() const { return s_; }

    /// A link whose ends are planar face clusters or surface elements, at
    /// least one a face cluster (the links `face_separation` governs).
    bool faceLink(const LinkEnd& r, const LinkEnd& s) const;

    /// Links with a planar face cluster at one end whose centroids do not
    /// face each other (kernel 0) may still exchange light where an end's
    /// bounding sphere reaches in front of the other end's plane; true when
    /// that holds for every flat end (surface element or planar face
    /// cluster; a volume cluster has no plane).
    bool straddles(const LinkEnd& r, const LinkEnd& s) const;
    /// The cluster end to open (the larger when both are clusters).
    Opening openLarger(const LinkEnd& r, const LinkEnd& s) const;

    /// Both ends flat and in one plane (ClusterTree::flatFace for clusters):
    /// they exchange no light.
    bool coplanar(const LinkEnd& r, const LinkEnd& s) const;

  private:
    /// The stand-in of overlapping ends with few surfaces (at most
    /// cluster.stand_in_pairs pairs): every receiver surface k against every
    /// sender surface j, F_kj = the mean over jittered points x of k (at
    /// least kSurfacePoints, and n / 2 over all of r) of the exact
    /// unoccluded point-to-polygon form factor F(x -> j) times the
    /// visibility of one ray drawn in proportion to the kernel over j
    /// (uniform over j's solid angle, Arvo 1995, accepted with probability
    /// cos_x; a point by area on a polygon below kMinSolidAngle).
    /// K = sum_kj A_k F_kj / A_r;
    /// the samples are the sender surfaces with sum_k A_k F_kj / A_r. The
    /// judged estimate shares the points and form factors and casts its own
    /// rays; its relative error is twice the standard error from the
    /// spread of each surface's point values. Same contract as standIn();
    /// called by it for overlapping spheres, where vis_ is set.
    ClusterLink standInBySurfaces(const LinkEnd& r, const LinkEnd& s,
                                  std::vector<StandInSample>* samples, bool judge) const;
    /// Root patches below a cluster end (1 for a surface element).
    uint64_t surfaceCount(const LinkEnd& e) const;
    static constexpr int kSurfacePoints = 4;
    /// Whether the surface point x on `patch` belongs to end e (a patch
    /// below the cluster, or inside the surface element's domain).
    bool holds(const LinkEnd& e, uint32_t patch, const Vec3& x) const;
    /// Monte Carlo transfer of a near pair (cluster.near = sample).
    ClusterLink sampledLink(const LinkEnd& r, const LinkEnd& s, std::span<const RGB> rootB) const;
    /// E[cos+(n_x, u)] over the surfaces below the receiving cluster r: the
    /// share of a sampled link's power the oriented push hands over per unit K.
    double receiverCosine(const LinkEnd& r, const Vec3& u) const;
    /// A uniform point (by area) on the surfaces below e; `patch` its patch.
    Vec3 uniformPoint(const LinkEnd& e, Pcg32& rng, uint32_t& patch) const;

    const scene::Scene* scene_;
    const ClusterTree* tree_;
    ClusterModel model_;
    const transport::Visibility* vis_;
    ClusterLinkSettings s_;
    /// Prefix sums of A_k max_c senderRadiosity(k) in the tree's patch order
    /// (prepareSenders).
    std::vector<double> senderPrefix_;
    /// m_k = max_c senderRadiosity(k) by patch (prepareSenders), the float
    /// the prefix sums add up: the density standIn() draws sender points by.
    std::vector<float> senderM_;
    RGB ambient_{0.0};
    /// B_k + rho_k ambient: what a sending cluster's points are drawn by.
    RGB senderRadiosity(uint32_t patch, const RGB& B) const;
    /// A patch below node nd drawn by the prefix sums from u in [0, 1)
    /// (the node's prefix range must be positive).
    uint32_t senderPatch(const ClusterNode& nd, double u) const;
};

}  // namespace hrad::cluster
