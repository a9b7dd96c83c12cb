// The element hierarchy and its links, in flat arrays.
//
// Nodes live in a structure of arrays addressed by 32-bit indices:
//   [0, k)          the root elements of the k root patches (node i = patch i)
//   [k, k + C)      the C clusters of the cluster tree, when clustering is on
//                   (node k + c = cluster c, in the tree's pre-order)
//   [k + C, ...)    sub-elements (quadtree nodes, scene/element.h), allocated
//                   four at a time and contiguous, so an element stores only
//                   the index of its first child.
// A root patch's parent is its leaf cluster; a cluster's children are its
// sub-clusters or, for a leaf cluster, its root patches. Links are stored with
// their receiver in compressed-row form (CSR): offsets per receiver element,
// then 16-byte Link records holding the sender, the transfer coefficient and
// what refinement needs. Gather runs in parallel over receivers without locks.
// (DESIGN.md "Core model"; the 16-byte link is a measured target.)
//
// Polynomial bases (hr.basis, scene/basis.h). B(e) is always the mean
// radiosity of e (the coefficient of phi_0 = 1), so the constant basis is
// today's solver unchanged, bit for bit. With a basis of degree p > 0 each
// surface element also stores the coefficients c_1..c_{n-1} per RGB channel
// (hi()), surface-surface links carry Galerkin coupling matrices K^{ab}
// (transport/coupling.h, set by setCoupling()), gather() gathers every
// coefficient over them, and push-pull moves coefficients with the exact
// two-scale relations. Links touching a cluster exchange only the constant
// term (Bekaert & Willems 1996; Sillion 1995): a cluster sends and receives
// its mean radiosity.
#pragma once

#include <array>
#include <atomic>
#include <cmath>
#include <bit>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <unordered_map>
#include <vector>

#include "cluster/transfer.h"
#include "cluster/transfer_model.h"
#include "cluster/tree.h"
#include "core/memory.h"
#include "core/types.h"
#include "scene/basis.h"
#include "scene/element.h"
#include "scene/field.h"
#include "scene/scene.h"

namespace hrad::cluster {
class SurfaceOpenness;
}
namespace hrad::transport {
class Visibility;
}

namespace hrad::hr {

inline constexpr uint32_t kNone = UINT32_MAX;

/// One link, stored in the receiver's row. 16 bytes.
struct Link {
    uint32_t sender = kNone;
    float K = 0.f;       ///< transfer coefficient: F_rs with visibility
    /// One float, three meanings by kind; read and write it through the
    /// accessors below: upperF() for a surface or point-approximation link
    /// (a bound on the unoccluded F_rs; the unoccluded F itself under judged
    /// visibility), judgedF() for a sampled link (kSampled: the judged
    /// estimate of F), sampleBlock() for a stand-in from a sending cluster
    /// (the index of its samples in the hierarchy).
    float Fupper = 0.f;
    /// Visibility fraction, quantised to 1/65535. For links touching a
    /// cluster it is the estimate the oracle judges with, from rays
    /// independent of those in K (hr/solver.h).
    uint16_t visibility = 0;
    /// kPartial | kOpen | kUncertain | kSampled | kDeferred | kHandedOver |
    /// kOpenHandOver | kStandIn
    uint8_t flags = 0;
    /// kSampled links: twice the relative standard error of the judged
    /// transfer, in percent, rounded up (255: 2.55 or more).
    uint8_t uncertainty = 0;

    static constexpr uint8_t kPartial = 1;
    /// A cluster link whose point approximation is not valid (a self-link,
    /// a single-surface cluster, overlapping bounding spheres): it carries
    /// nothing and is opened in the next refinement round, whatever the oracle.
    static constexpr uint8_t kOpen = 2;
    /// A link whose judged visibility rays were all blocked: it may carry a
    /// little (a doorway), so it is kept and judged with the unoccluded
    /// transfer times a bound on the visibility (hr/link_estimate.cpp), not
    /// dropped (papers/notes/2026-11-29-hr-solver-notes.md, "Judged visibility").
    static constexpr uint8_t kUncertain = 4;
    /// A near cluster pair whose transfer is a Monte Carlo estimate
    /// (cluster/link.h): Fupper holds the judged estimate of F (receiver
    /// factor included) instead of a bound, `uncertainty` its error.
    static constexpr uint8_t kSampled = 8;
    /// A link from a cluster that carried no light when it was made
    /// (cluster.defer_dark): nothing computed (K = 0, no rays); computed, with
    /// the cluster's radiosities, in the first judging pass after it carries light.
    static constexpr uint8_t kDeferred = 16;
    /// A link into an oriented cluster whose hand-over has been decided
    /// (cluster.handover = visible; hr/openness_handover.h), once, when
    /// the link is first set: by cosine and openness (kOpenHandOver, its K
    /// divided by the cluster's openness towards the sender) or, where no
    /// surface is open, by cosine alone. On a stand-in without kHandedOver,
    /// kOpenHandOver means by what each surface sees (Link::bySeen).
    static constexpr uint8_t kHandedOver = 32;
    static constexpr uint8_t kOpenHandOver = 64;
    /// A link that had to be opened when refinement stopped early, given a
    /// sampled stand-in transfer (cluster.stand_in; cluster/link.h
    /// "Stand-ins"; also kSampled). K is its mean form factor; from a
    /// sending cluster it gathers through its samples (Hierarchy::standInSent;
    /// `Fupper` then holds the index of its sample block, not a bound), from
    /// a surface element K times its radiosity. A receiving cluster takes
    /// the light by area; with kHandedOver (cluster/link.h: spheres apart,
    /// oriented receiver) by its surfaces' cosines towards the sender, as a
    /// point-approximation link's (no openness).
    static constexpr uint8_t kStandIn = 128;
    /// A stand-in whose receiving cluster does not take its light by cosine
    /// (no direction): by area, or, with kOpenHandOver, by what each surface
    /// sees of the sender (hr/openness_handover.h).
    bool byArea() const { return (flags & kStandIn) && !(flags & kHandedOver); }
    /// A by-area stand-in handed over by what each surface sees of the sender.
    bool bySeen() const { return byArea() && (flags & kOpenHandOver); }

    float upperF() const { return Fupper; }
    void setUpperF(double f) { Fupper = float(f); }
    float judgedF() const { return Fupper; }
    void setJudgedF(double f) { Fupper = float(f); }
    uint32_t sampleBlock() const { return std::bit_cast<uint32_t>(Fupper); }
    void setSampleBlock(uint32_t b) { Fupper = std::bit_cast<float>(b); }

    double vis() const { return visibility / 65535.0; }
    void setVis(double v) {
        double c = v < 0 ? 0 : (v > 1 ? 1 : v);
        visibility = uint16_t(c * 65535.0 + 0.5);
    }
};
static_assert(sizeof(Link) == 16, "Link must stay 16 bytes");

/// Unoccluded point form factors of a link at its receiver's kernel sample
/// points (FormFactorEngine::kernelSamples), or with a polynomial basis the
/// kernel less the link's projection there, cached per link for the
/// receiver-aggregate error (hr/receiver_error.h): geometry only, computed
/// once. Stored only for surface-to-surface links whose receiver can still
/// subdivide, in link order (Hierarchy::storesKernelSamples).
///
/// 24 bytes, not nine floats' 36: the mean as a float and each sample's
/// deviation as a 16-bit integer times a per-link power of two, so the
/// aggregate (which needs the deviations) keeps a rounding error of at most
/// 1/32767 of the link's largest deviation; half floats would round each
/// sample to 2^-11 of itself, more than the variation the check looks for.
class KernelSamples {
  public:
    static constexpr int kCount = 9;
    KernelSamples() = default;
    /// Packs the first m (<= kCount) of v; the others read as the mean.
    KernelSamples(const double* v, int m);
    /// Sample k (the packed value to within 1/32767 of the largest deviation).
    double operator[](int k) const { return double(mean_) + double(q_[size_t(k)]) * step(); }
    static constexpr int size() { return kCount; }
    double mean() const { return double(mean_); }
    /// Sample k less the mean, in units of step().
    double deviation(int k) const { return double(q_[size_t(k)]); }
    /// The value of one unit of the stored deviations.
    double step() const { return std::ldexp(1.0, exp_); }

  private:
    float mean_ = 0.f;
    std::array<int16_t, kCount> q_{};
    int16_t exp_ = 0;
};
static_assert(sizeof(KernelSamples) == 24, "kernel samples must stay 24 bytes");

class HandOver;
class ElementRho;

class Hierarchy {
  public:
    /// Without a cluster tree (or with model None) there are no cluster nodes.
    explicit Hierarchy(const scene::Scene& scene, const cluster::ClusterTree* tree = nullptr,
                       cluster::ClusterModel model = cluster::ClusterModel::None,
                       int basisDegree = 0);
    ~Hierarchy();
    Hierarchy(Hierarchy&&) noexcept;
    Hierarchy& operator=(Hierarchy&&) noexcept;

    // ---- polynomial basis -------------------------------------------------------
    int basisDegree() const { return basis_ ? basis_->degree() : 0; }
    /// Number of basis functions (1 for the constant basis).
    int basisSize() const { return nb_; }
    /// The bases (null for the constant basis).
    const scene::BasisSet* basis() const { return basis_.get(); }
    /// Coefficients c_1..c_{n-1} of node e (n = basisSize(); empty span for
    /// the constant basis). Clusters' stay zero.
    const RGB* hi(uint32_t e) const { return hi_.data() + size_t(e) * size_t(nb_ - 1); }
    RGB* hi(uint32_t e) { return hi_.data() + size_t(e) * size_t(nb_ - 1); }
    /// Gathered higher coefficients of e (gather() writes them).
    RGB* gatheredHi(uint32_t e) { return gatheredHi_.data() + size_t(e) * size_t(nb_ - 1); }
    /// Every node's higher coefficients (for a copy one iteration earlier).
    const std::vector<RGB>& allHi() const { return hi_; }
    /// Radiosity of surface element e at its local coordinates (a, b)
    /// (scene/element.h domainParam): the polynomial.
    RGB evaluate(uint32_t e, double a, double b) const;
    /// Coupling matrices of the current links: coupling(i) is the K^{ab}
    /// (row-major n x n) of link i, or null for a link that exchanges only
    /// the constant term (links touching a cluster) and uses Link::K.
    const float* coupling(uint64_t i) const {
        return couplingIndex_.empty() || couplingIndex_[i] == kNone
                   ? nullptr
                   : couplingData_.data() + size_t(couplingIndex_[i]) * size_t(nb_ * nb_);
    }
    /// Sets the coupling matrices of the current links (index per link, kNone
    /// for none; data n*n floats per entry).
    void setCoupling(std::vector<uint32_t>&& index, std::vector<float>&& data);
    const std::vector<uint32_t>& couplingIndex() const { return couplingIndex_; }
    const std::vector<float>& couplingData() const { return couplingData_; }

    const scene::Scene& scene() const { return *scene_; }
    /// Number of nodes (elements and clusters).
    uint32_t numElements() const { return uint32_t(patch_.size()); }
    uint32_t numPatches() const { return uint32_t(scene_->patches.size()); }
    uint32_t numClusters() const { return numClusters_; }
    cluster::ClusterModel clusterModel() const { return model_; }
    /// The transfer model of clusterModel() (cluster/transfer_model.h).
    const cluster::TransferModel& transferModel() const { return *transfer_; }
    const cluster::ClusterTree* clusterTree() const { return tree_; }
    /// How links into clusters hand their light to the surfaces below
    /// (hr/handover.h; "none" until set). The solver sets the one its
    /// transfer model names, before the links: each link gets its hand-over
    /// once, when setLinks() first sees it.
    void setHandOver(std::unique_ptr<HandOver> handOver);
    const HandOver& handOver() const { return *handOver_; }
    bool isCluster(uint32_t e) const {
        return e >= numPatches() && e < numPatches() + numClusters_;
    }
    /// Cluster tree index of a cluster node.
    uint32_t clusterIndex(uint32_t e) const { return e - numPatches(); }
    uint32_t rootCluster() const { return numPatches(); }
    /// Children of any node: 4 for a subdivided element, the sub-clusters or
    /// root patches of a cluster, none for a leaf element.
    uint32_t numChildren(uint32_t e) const;
    uint32_t child(uint32_t e, uint32_t i) const;
    /// Area-weighted centroid, and the radius of a sphere around it containing the node.
    Vec3 center(uint32_t e) const;
    double radius(uint32_t e) const;
    /// Mean reflectance (a cluster's is area-weighted over its surfaces; an
    /// element of a textured patch under hr.texture_rho = element its own,
    /// hr/element_rho.h).
    RGB rho(uint32_t e) const;
    /// hr.texture_rho = element: elements of textured root patches carry
    /// their own reflectance (hr/element_rho.h). Set before any subdivision;
    /// no-op for a scene without textured patches.
    void setElementRho(bool on);
    /// Whether element e gathers irradiance and its leaves apply their own
    /// reflectance in push-pull (an element of a textured root patch under
    /// setElementRho); false for clusters and every untextured patch.
    bool pushesIrradiance(uint32_t e) const;
    /// The factor gatherRow applies to what surface element e gathers: its
    /// root patch's rho, or 1 where e pushes irradiance (pushesIrradiance).
    RGB gatherReflectance(uint32_t e) const;
    /// sum over the leaves l below surface element e of A_l rho_l: the power
    /// e reflects per unit of irradiance it gathers (A_e rho_patch where e
    /// does not push irradiance).
    RGB reflectingArea(uint32_t e) const;
    /// Bytes of the per-element reflectance table (0 without one).
    uint64_t elementRhoBytes() const;

    // ---- element attributes -------------------------------------------------
    uint32_t patch(uint32_t e) const { return patch_[e]; }
    scene::ElementKey key(uint32_t e) const { return key_[e]; }
    /// Quadtree level of an element; 0 for clusters.
    int level(uint32_t e) const { return key_[e] ? scene::keyLevel(key_[e]) : 0; }
    uint32_t parent(uint32_t e) const { return parent_[e]; }
    uint32_t firstChild(uint32_t e) const { return firstChild_[e]; }
    /// A surface element with no children (clusters are never leaves).
    bool isLeaf(uint32_t e) const { return firstChild_[e] == kNone && patch_[e] != kNone; }
    double area(uint32_t e) const { return area_[e]; }
    scene::Domain domain(uint32_t e) const;
    const RGB& B(uint32_t e) const { return B_[e]; }
    /// Every node's B (for a copy one iteration earlier).
    const std::vector<RGB>& allB() const { return B_; }
    RGB& B(uint32_t e) { return B_[e]; }
    const RGB& gathered(uint32_t e) const { return gathered_[e]; }
    RGB& gathered(uint32_t e) { return gathered_[e]; }
    std::vector<RGB> lightGathered;  ///< rho E from non-area lights per node, added by gatherRow (hr/light_links.h)
    /// Stable id of an element, independent of allocation order (seeds rays),
    /// drawn under the solve's seed (setSeed).
    uint64_t stableId(uint32_t e) const;
    /// The solve's seed (hr.seed): 0 keeps the fixed seeding; any other value
    /// draws every ray the hierarchy's links and hand-overs cast from other
    /// streams. Set before the first link is made.
    void setSeed(uint64_t seed) { seed_ = seed; }

    /// Creates the four children of a leaf (no-op when already subdivided).
    /// Children inherit the parent's B. Not thread-safe.
    void subdivide(uint32_t e);
    /// Makes room for `more` elements beyond the current ones, exactly (a
    /// refinement round knows how many it makes: growing by doubling left
    /// up to half of every element array unused).
    void reserveElements(size_t more);
    /// Number of surface elements that are leaves (clusters excluded).
    uint32_t numLeaves() const;

    // ---- links ----------------------------------------------------------------
    /// Replaces all links. `receivers[i]` is the receiver of links[i]; the
    /// arrays are sorted stably by receiver into CSR form.
    void setLinks(const std::vector<uint32_t>& receivers, std::vector<Link>&& links);
    /// The same with the links' kernel samples: one per link that
    /// storesKernelSamples(), in the order of those links in `links`.
    void setLinks(const std::vector<uint32_t>& receivers, std::vector<Link>&& links,
                  std::vector<KernelSamples>&& samples);
    /// Stores the samples of a stand-in from a sending cluster and returns
    /// the index of their block (for the link's Fupper; not thread-safe).
    /// setLinks keeps only the blocks its links refer to.
    uint32_t addStandIn(std::span<const cluster::StandInSample> samples, float judged);
    /// Surface-to-surface links with a judged visibility (hr.judge_visibility
    /// = independent; hr/link_builder.h): Link::visibility holds an
    /// estimate from rays independent of those in K, the one the oracle
    /// judges, and Fupper the unoccluded form factor (the conservative bound
    /// is recomputed where needed). Otherwise Link::visibility is the
    /// fraction in K and Fupper the bound. Set by the solver before linking.
    void setJudgedSurfaceVisibility(bool on) { judgedSurfaceVis_ = on; }
    /// A surface-to-surface link's unoccluded form factor and the visibility
    /// fraction K carries (K = unoccluded x carried), in either layout.
    double unoccludedF(const Link& l) const {
        if (judgedSurfaceVis_) return l.upperF();
        const double v = l.vis();
        return v > 0 ? double(l.K) / v : 0.0;
    }
    double carriedVisibility(const Link& l) const {
        if (!judgedSurfaceVis_) return l.vis();
        return l.upperF() > 0 ? std::min(1.0, double(l.K) / double(l.upperF())) : 0.0;
    }
    /// The transfer refinement judges stand-in link l by, per unit receiver
    /// area: its independent estimate (cluster.near = stand_in) or K itself.
    double standInJudged(const Link& l) const;
    /// What stand-in link l sends its receiver per unit area (irradiance):
    /// the sum over its samples of weight times the current radiosity of
    /// the sample's root patch; from a surface element, K times its radiosity.
    RGB standInSent(const Link& l) const;
    /// The power receiver r reflects of what stand-in link l delivers:
    /// standInSent times sum_k A_k rho_k over r's surfaces, each weighted by
    /// its cosine towards the sender when the link is handed over by cosine
    /// (as the push delivers it, clusterIrradianceAt).
    RGB standInReflected(uint32_t r, uint64_t i) const;
    uint64_t standInSampleCount() const {
        return standInSamples_.size() - (standInBegin_.size() - 1);  // without the block headers
    }
    /// Whether link l into receiver r has kernel samples: both ends are
    /// surface elements. Depends on the pair only, never on the link's flags.
    /// These are the links the receiver aggregate sums (hr/receiver_error.h).
    bool carriesKernelSamples(uint32_t r, const Link& l) const {
        return l.sender != kNone && !isCluster(r) && !isCluster(l.sender);
    }
    /// Whether the samples of such a link are stored: only when its receiver
    /// can subdivide. Only the receiver's subdivision lowers its aggregate
    /// (oracles::receiverRefinement), so no decision reads the aggregate of a
    /// receiver that cannot; the error estimate computes their samples when
    /// it needs them (receiverErrors). Where most receivers are at the
    /// smallest area (finely tessellated scenes) this keeps most links
    /// without samples. Depends on the pair only.
    bool storesKernelSamples(uint32_t r, const Link& l) const {
        return carriesKernelSamples(r, l) && canSubdivide(r);
    }
    /// The subdivision limits (hr.min_area, hr.max_level), set by the solver
    /// before any link is placed; without them every surface element may
    /// subdivide.
    void setSubdivisionLimits(double minArea, int maxLevel) {
        minArea_ = minArea;
        maxLevel_ = maxLevel;
    }
    /// Whether element e may subdivide: a cluster always (it is opened), a
    /// surface element below the level limit whose children keep the
    /// smallest area.
    bool canSubdivide(uint32_t e) const {
        return isCluster(e) || (level(e) < maxLevel_ && 0.25 * area(e) >= minArea_);
    }
    /// Whether the links carry their kernel samples (set by the last
    /// setLinks() with samples).
    bool hasKernelSamples() const { return hasSamples_; }
    /// The kernel samples of the links that storesKernelSamples(), in link
    /// order (empty unless hasKernelSamples()).
    const std::vector<KernelSamples>& kernelSamples() const { return samples_; }
    /// Moves the cached samples out (refinement hands them back with setLinks).
    std::vector<KernelSamples> takeKernelSamples() {
        std::vector<KernelSamples> out = std::move(samples_);
        samples_.clear();
        hasSamples_ = false;
        return out;
    }
    /// The most links a hierarchy holds: its row offsets are 32-bit (64 GiB
    /// of 16-byte links, past the memory of the machines it runs on).
    static constexpr uint64_t kMaxLinks = UINT32_MAX;
    uint64_t numLinks() const { return links_.size(); }
    /// Links of receiver e: [linkBegin(e), linkEnd(e)).
    uint64_t linkBegin(uint32_t e) const {
        return e < linkOffsets_.size() - 1 ? linkOffsets_[e] : links_.size();
    }
    uint64_t linkEnd(uint32_t e) const {
        return e < linkOffsets_.size() - 1 ? linkOffsets_[e + 1] : links_.size();
    }
    /// Moves the links out and leaves the hierarchy with none (every row
    /// empty; the cluster link directions and coupling matrices, which
    /// belong to them, dropped too): refinement holds one copy of the links,
    /// not two, and hands them back with setLinks().
    std::vector<Link> takeLinks();
    const Link& link(uint64_t i) const { return links_[i]; }
    const std::vector<Link>& links() const { return links_; }
    /// Receiver of every link (expanded from CSR).
    std::vector<uint32_t> linkReceivers() const;

    // ---- solution -------------------------------------------------------------
    /// B_r^g = rho_r * sum_links K B_s for every receiver (parallel over receivers).
    void gather();
    /// Push gathered radiosity down (unchanged, it is per unit area), set leaves
    /// to E + sum of gathered on the path, pull area-weighted averages up.
    /// Parallel over root patches. With clusters, irradiance gathered by a
    /// cluster reaches its root patches first (isotropic: unchanged; oriented:
    /// per link with each patch's own cosine and the sender's directionalB()
    /// towards the receiving cluster, as gather() uses for cluster senders;
    /// see cluster/transfer.h), and clusters pull the area-weighted average
    /// (and maxB()) of their children.
    void pushPull();
    /// One block Gauss-Seidel sweep in place of gather() + pushPull()
    /// (hr.iteration = gauss-seidel, HrSolver): cluster rows gather first,
    /// from the previous radiosities; then the root patches, in index order
    /// split into `blocks` contiguous blocks, gather and push-pull block after
    /// block, so each block gathers from the radiosities the blocks before it
    /// have just computed. Within a block all rows gather before any B is
    /// rewritten (parallel, and the result is the same for any thread count);
    /// clusters pull at the end. With one block it is gather() + pushPull().
    /// `gatherSeconds` and `pushPullSeconds` receive the time of each phase.
    void sweep(int blocks, double* gatherSeconds = nullptr, double* pushPullSeconds = nullptr);
    /// What relax() did.
    struct RelaxResult {
        int sweeps = 0;
        uint64_t linkReads = 0;    ///< links read, all sweeps together (iterationLinkReads' unit)
        bool reached = false;      ///< stopped because the tail fell below `target`
    };
    /// The links one iteration (gather() and pushPull()) reads, in relax()'s
    /// unit: every link once, and with oriented clusters each link into a
    /// cluster once more for every root patch below it (the push hands it
    /// to each surface with that surface's cosine, clusterIrradianceAt).
    uint64_t iterationLinkReads() const;
    /// Relaxes a few root patches alone (hr.relax_share, HrSolver): Gauss-
    /// Seidel sweeps over `roots`, each root gathering its rows from the
    /// current radiosities and pushing and pulling at once, with everything
    /// else held (other patches, and the irradiance clusters hand these
    /// roots). Stops after `maxSweeps`, before the links read would pass
    /// `linkBudget`, or when the change still to come, a geometric tail
    /// with the rate over two sweeps, is below `target` (power: A times
    /// radiosity, max channel). Clusters pull at the end. The fixed point is
    /// the solve's own, so it only changes how fast the iteration gets there.
    /// Constant basis only.
    RelaxResult relax(const std::vector<uint32_t>& roots, int maxSweeps, uint64_t linkBudget,
                      double target);
    /// Moves every leaf's radiosity along the change from `previous` (the
    /// B of the same elements one iteration earlier), per channel:
    /// B += factor_c (B - previous), then pulls the averages up again
    /// (surface elements and clusters). Extrapolates the geometric tail of
    /// the gather iteration (see HrSolver, hr.extrapolate).
    void extrapolateLeaves(const std::vector<RGB>& previous, const RGB& factor);
    /// The same for a polynomial basis: `previousHi` are allHi() one
    /// iteration earlier (every coefficient moves along its change).
    void extrapolateLeaves(const std::vector<RGB>& previous, const std::vector<RGB>& previousHi,
                           const RGB& factor);
    /// Sum over leaves of A (B - E): the reflected power (RGB).
    RGB reflectedPower() const;
    /// The light each link brings, as gather() and pushPull() deliver it:
    /// `reflected[i]` is the power link i's receiver reflects of what the
    /// link sends (a surface element: A_r rho_r times it; a cluster: summed
    /// over the surfaces below with the share each takes: cosine, openness,
    /// seen weights, or by area). Over all links it sums to
    /// reflectedPower() up to the iteration's residual (the senders' B is
    /// today's, the leaves' was gathered from the iteration before).
    /// With `relError` (per link, the relative standard error of its
    /// transfer, 0 for exact links), also `patchVariance`: per root patch,
    /// the variance of its mean reflected radiosity that independent errors
    /// of that size cause directly, before the light they move is reflected
    /// on (hr/noise.h). Constant term only for a polynomial basis.
    void linkLight(std::vector<RGB>& reflected, const std::vector<float>* relError = nullptr,
                   std::vector<RGB>* patchVariance = nullptr) const;
    /// Sum over leaves of A * B (RGB).
    RGB radiosityPower() const;

    // ---- memory ----------------------------------------------------------------
    uint64_t elementBytes() const;
    uint64_t linkBytes() const;
    void reportMemory(MemoryCounters& m) const;

    /// Radiosity leaving cluster node e towards unit direction d, averaged
    /// over its projected area (oriented model: surfaces facing d weigh by
    /// A_k cos; Smits et al. 1994). Falls back to the mean B when nothing
    /// faces d. For elements and isotropic clusters: B(e).
    RGB directionalB(uint32_t e, const Vec3& d) const;
    /// Largest radiosity (per channel) of the root patches below cluster node
    /// e (root patches hold the area average of their leaves); B(e) for an
    /// element. Refinement judges links from a cluster with it (hr/solver.h).
    RGB maxB(uint32_t e) const { return isCluster(e) ? maxB_[clusterIndex(e)] : B_[e]; }

  private:
    struct PushFrame {
        uint32_t e;
        RGB down;
        int next;  ///< next child to visit (0..4)
    };
    /// Gathers receiver r's row (K times B; coupling matrices for a
    /// polynomial basis) into gathered_ (and gatheredHi_).
    void gatherRow(uint32_t r);
    /// Irradiance the clusters hand each root patch after their rows have
    /// gathered (reflectance applied); empty without clusters.
    std::vector<RGB> clusterIrradianceToRoots() const;
    /// Per cluster, sum over the textured root patches below it of
    /// reflectingArea(root) - A_root rho_root (`rootReflecting` holds the
    /// first term per root patch): what their leaves reflect beyond the
    /// tree's patch means (empty without setElementRho or clusters).
    std::vector<RGB> textureReflectingExcess(const std::vector<RGB>& rootReflecting) const;
    /// Per cluster, the isotropic irradiance it and its ancestors gathered.
    std::vector<RGB> clusterDown() const;
    /// Oriented model: calls f(i, w) for every link i in cluster element c's
    /// row that the push hands root patch `root` (below c), w the share of
    /// what the link sends per unit area that the patch takes before its
    /// reflectance: its cosine towards the sender, times what the hand-over
    /// gives links it flagged (openShares), then the hand-over's stand-in
    /// shares (forEachSurfaceShare). Links by area (gathered_) are not visited.
    template <class F>
    void forEachShare(uint32_t c, uint32_t root, F&& f) const;
    /// What link i of receiver r's row sends per unit area, before r's
    /// reflectance (gatherRow): a stand-in's standInSent, K times the
    /// sender's B, or, from an oriented cluster, K times its radiosity
    /// towards `receiverCenter` (r's centre; null for the mean B). The
    /// constant term for a polynomial basis.
    RGB rowSent(uint64_t i, const Vec3* receiverCenter) const;
    /// The irradiance clusters hand root patch `root` (reflectance applied):
    /// `down` from clusterDown(); `sent` what every link into a cluster sends
    /// (oriented), or null to evaluate it here.
    RGB clusterIrradianceAt(uint32_t root, const std::vector<RGB>& down,
                            const glm::vec3* sent) const;
    /// Push-pull below one root patch: leaves get E + gathered on the path
    /// (plus `fromAbove`), inner elements the area average of their children.
    void pushPullRoot(uint32_t root, const RGB& fromAbove, std::vector<PushFrame>& stack);
    void prepareOrientedDirections();
    /// Push-pull of the polynomial coefficients (basis degree > 0).
    void pushPullPolynomial(const std::vector<RGB>& fromAbove);
    /// Pull of the coefficients of e from its four children (degree > 0).
    void pullPolynomial(uint32_t e);
    /// Bottom-up over clusters: area-weighted mean B and, for the oriented
    /// model, the radiosity-weighted normal moments used by directionalB().
    void pullClusters();
    /// Pulls cluster c (tree index) from its children: B, maxB, moments.
    void pullCluster(uint32_t c);
    const scene::Scene* scene_;
    const cluster::ClusterTree* tree_ = nullptr;
    std::unique_ptr<HandOver> handOver_;  ///< setHandOver
    std::unique_ptr<ElementRho> elementRho_;  ///< setElementRho (null: one rho per root patch)
    cluster::ClusterModel model_ = cluster::ClusterModel::None;
    const cluster::TransferModel* transfer_ = nullptr;
    uint32_t numClusters_ = 0;
    /// Oriented model: unit direction from each cluster-receiver link's
    /// receiver to its sender, for the links of cluster rows (contiguous).
    std::vector<glm::vec3> clusterLinkDir_;
    /// What link i into an oriented cluster sends: K times the sender's
    /// radiosity towards the receiver (`dir` points from receiver to
    /// sender), or a stand-in's standInSent.
    RGB linkSent(uint64_t i, const glm::vec3& dir) const;
    /// Drops the stand-in sample blocks no link refers to (setLinks).
    void compactStandIns();
    uint64_t clusterLinkBase_ = 0;
    /// Models that send by direction: per cluster, the radiant moments of
    /// the surfaces below (cluster/transfer_model.h).
    using RadiantMoments = cluster::RadiantMoments;
    std::vector<RadiantMoments> moments_;
    /// Per cluster: largest radiosity of the root patches below (maxB()).
    std::vector<RGB> maxB_;
    // Elements (structure of arrays).
    std::vector<uint32_t> patch_;
    std::vector<scene::ElementKey> key_;
    std::vector<uint32_t> parent_;
    std::vector<uint32_t> firstChild_;
    std::vector<double> area_;
    std::vector<RGB> B_;
    std::vector<RGB> gathered_;
    // Polynomial basis (degree > 0): nb_ - 1 higher coefficients per node.
    std::unique_ptr<scene::BasisSet> basis_;
    int nb_ = 1;
    std::vector<RGB> hi_;
    std::vector<RGB> gatheredHi_;
    // Links (CSR by receiver).
    /// Row starts of the links in CSR order, 32-bit: a hierarchy holds at
    /// most kMaxLinks links (refinement stops before a round would pass it).
    std::vector<uint32_t> linkOffsets_;
    std::vector<Link> links_;
    std::vector<KernelSamples> samples_;
    bool hasSamples_ = false;
    double minArea_ = 0.0;  ///< setSubdivisionLimits
    int maxLevel_ = std::numeric_limits<int>::max();
    void placeLinks(const std::vector<uint32_t>& receivers, std::vector<Link>&& links,
                    std::vector<KernelSamples>* samples);
    /// Stand-in samples (addStandIn): block b is
    /// standInSamples_[standInBegin_[b] .. standInBegin_[b + 1]).
    std::vector<uint64_t> standInBegin_{0};
    std::vector<cluster::StandInSample> standInSamples_;
    bool hasStandIns_ = false;  ///< some link is a stand-in (Link::kStandIn)
    bool judgedSurfaceVis_ = false;  ///< setJudgedSurfaceVisibility
    uint64_t seed_ = 0;              ///< setSeed
    std::vector<uint32_t> couplingIndex_;
    std::vector<float> couplingData_;
};

/// The hierarchical solution viewed as a RadiosityField (the values are the
/// hierarchy's B after push-pull: leaves carry the solution, inner nodes the
/// exact area-weighted averages of their leaves).
class HierarchyField final : public scene::RadiosityField {
  public:
    explicit HierarchyField(const Hierarchy& h) : h_(&h) {}
    const scene::Scene& scene() const override { return h_->scene(); }
    RGB at(uint32_t patch, double u, double v) const override;
    RGB average(uint32_t patch, scene::ElementKey key) const override;
    void forEachLeaf(uint32_t patch,
                     const std::function<void(scene::ElementKey, const RGB&)>& fn) const override;
    /// The leaf's polynomial at (a, b) (the leaf value for the constant basis).
    RGB leafPoint(uint32_t patch, scene::ElementKey key, const RGB& leafValue, double a,
                  double b) const override;
    int basisDegree() const override;
    void leafHigherCoefficients(uint32_t patch, scene::ElementKey key, RGB* out) const override;

  private:
    /// The element of `patch` at `key` (which must be a node of its quadtree).
    uint32_t elementAt(uint32_t patch, scene::ElementKey key) const;
    const Hierarchy* h_;
};

}  // namespace hrad::hr
