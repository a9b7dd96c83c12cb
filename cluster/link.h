// Links that touch a cluster: when the point approximation is valid, the
// transfer it gives, visibility by rays, and the Monte Carlo transfers that
// stand in where it is not (Smits, Arvo & Greenberg 1994; Sillion 1995).
// hr/ asks for a link between two nodes described by a plain LinkEnd;
// cluster/ does not see the hierarchy. The reasons and measurements behind
// every choice below: papers/notes/2026-12-01-cluster-transfer.md.
//
// Point links (link.cpp): K = A_s g_s(u) g_r(-u) / (pi r^2) (the transfer
// model's g, cluster/transfer_model.h) times a visibility fraction from rays
// whose end points follow the transfer's density over both ends' surfaces
// (receiver A_k cos_k, sender A_k (B_k + rho_k a) cos_k, a the ambient term
// of Cohen, Chen, Wallace & Greenberg 1988), kernel-weighted. The oracle
// judges an independent estimate (no selection bias); all judged rays blocked
// keeps the link with the 95 % bound 1 - 0.05^(1/n). Valid when the spheres
// are apart and, cluster to cluster, `separation` times the radii apart;
// planar face clusters (Willmott, Heckbert & Garland 1999) link like surfaces.
// Links from clusters that carry no light yet are deferred (defer_dark).
// Near pairs (near_pairs.cpp, cluster.near = sample): Monte Carlo kernel
// integration, stored as the K the gather turns back into that power.
// Stand-ins (stand_in.cpp): links left unopened when refinement stops early,
// and (cluster.near = stand_in) judged pairs too close for the point
// approximation, get a Monte Carlo transfer needing no direction: point pairs
// when the spheres are apart, and for overlapping spheres a cosine direction
// and a direction over a sender polygon's solid angle (Arvo 1995) combined by
// the balance heuristic (Veach & Guibas 1995); the sender drawn by a
// defensive mixture (Hesterberg 1995); the samples kept by root patch.
//
// Settings: the cluster.* keys (`hrad settings cluster.` lists them with
// their types, defaults and docs).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "cluster/transfer.h"
#include "cluster/transfer_model.h"
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
    /// cluster.sender_kernel: a link from a surface element into a cluster
    /// takes the exact form factor from a differential area at the
    /// receiver's centre, facing the sender's centroid, to the sender's
    /// polygon (transport::pointToPolygon; true, `polygon`), not the point
    /// model's A_s cos_s / (pi d^2) (false, `point`, the default): the point
    /// model misjudges a sender whose size is not small against the distance.
    bool polygonSender = false;
    /// cluster.kernel, a point link's geometric kernel: Point, the centres'
    /// 1 / r^2; Sampled, times r^2 times the mean of its rays' 1 / d^2
    /// (ClusterLinker::LinkRays::estimate); Pairs, times the ratio of the
    /// mean unoccluded cos_a cos_b / d^2 over kernelPairs area-uniform point
    /// pairs to the point model's g_r g_s / r^2 (LinkRays::pairKernel).
    enum class Kernel { Point, Sampled, Pairs };
    Kernel kernel = Kernel::Point;
    int kernelPairs = 32;
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
    /// The transfer model of model() (cluster/transfer_model.h).
    const TransferModel& transfer() const { return *transfer_; }
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
    /// The rays of one point-approximation link (link.cpp).
    class LinkRays;
    friend class LinkRays;
    /// link() for a pair the point approximation cannot take: a deferred
    /// or sampled near link, or `out` (to be opened).
    ClusterLink nearOrOpen(const LinkEnd& r, const LinkEnd& s, std::span<const RGB> rootB,
                           bool dark, ClusterLink& out) const;
    /// The point pairs of one sampled near link (near_pairs.cpp).
    class NearSampler;
    friend class NearSampler;
    /// The sampling of one stand-in (stand_in.cpp).
    class StandInSampler;
    friend class StandInSampler;
    /// standIn(): the judged visibility, partial and uncertain flags and
    /// relative error from the judged estimate's sums (`points` samples of
    /// `n` rays; judgedF set before, replaced by a bound when it found nothing).
    static void judgeStandIn(ClusterLink& out, double sum, double sum2, int cast, int found,
                             double unoccluded, int points, int n, bool apart);
    /// standIn(): the samples merged by patch, in patch order, times `scale`.
    static void mergeStandInSamples(std::vector<StandInSample>& local, double scale,
                                    std::vector<StandInSample>& samples);
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
    const TransferModel* transfer_;
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
