// The hand-over by openness (row "openness" of hr/handover.h): the oriented
// model's with cluster.handover = visible (cluster/oriented_model.h).
//
// Links into a receiving cluster (newLinks). The oriented model hands a
// link's light to every surface k below the cluster by its cosine towards
// the sender (Smits, Arvo & Greenberg 1994, sec. 4); here also by k's
// openness w_k towards the sender within the cluster (cluster/openness.h).
// Each link is decided once, when setLinks() first sees it: its K is divided
// by W = sum_k A_k cos_k w_k / sum_k A_k cos_k (OrientedModel::opennessSums,
// the same sums the push makes, so the link delivers the power it did by
// cosine) and flagged Link::kOpenHandOver; where W = 0 it stays by cosine.
// No surface takes more than the sender's unoccluded irradiance: K / W is
// held to the link's bound Fupper when one is set, since a surface gets
// K / W cos_k w_k with cos_k w_k <= 1; the power past it is not delivered
// (papers/notes/2026-12-01-cluster-transfer.md, "A sliver's K / W").
//
// Stand-ins that no direction hands over (standIns; Link::byArea, with
// cluster.stand_in_handover = seen) give surface k the share w_k / W of
// their irradiance, W = sum_k A_k w_k / sum_k A_k, so the power is unchanged
// and only where it lands moves (Link::bySeen):
//     w_k = sum over the sender's surfaces j of c_j sum over k's openness
//           points x of F(x -> j) v(x, j)    (OrientedModel::seenWeights),
// F the exact unoccluded point-to-polygon form factor, v a shadow ray, c_j
// j's largest radiosity channel (1 for a surface-element sender). A sender
// with more than kSeenMaxSources lit surfaces contributes that many drawn by
// A_j c_j, weighted so that the sum's expectation is the sum over all. The
// outer shell of a double-shelled lamp housing then gets nothing where by
// area it got as much as the inner shell (papers/README.md, "Where the
// classroom's stand-in error lives"). Decided once per (receiver, sender)
// pair, when the sender carries light, and kept across setLinks(); stays by
// area where the sender is dark, no surface sees it, or the pair has more
// than kSeenMaxPairs surface pairs to weigh.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include "cluster/oriented_model.h"
#include "hr/handover.h"

namespace hrad::hr {

class OpennessHandOver final : public HandOver {
  public:
    /// With `table` (owned by the caller, outliving this); `seenVisibility`
    /// casts the seen hand-over's shadow rays (null: stand-ins by area).
    OpennessHandOver(const scene::Scene& scene, const cluster::ClusterTree& tree,
                     const cluster::SurfaceOpenness& table,
                     const transport::Visibility* seenVisibility);
    /// The same owning the table.
    OpennessHandOver(const scene::Scene& scene, const cluster::ClusterTree& tree,
                     std::unique_ptr<cluster::SurfaceOpenness> table,
                     const transport::Visibility* seenVisibility);
    ~OpennessHandOver() override;

    const char* name() const override { return "openness"; }
    void newLinks(const HandOverLinks& h) override;
    void standIns(const HandOverLinks& h) override;
    void openShares(uint32_t c, uint32_t root, std::span<const glm::vec3> dirs,
                    std::span<double> w) const override;
    void forEachSurfaceShare(uint32_t c, uint32_t root, ShareFn f) const override;
    std::optional<RGB> surfaceReflected(uint32_t c, uint64_t i) const override;
    Counts counts() const override;
    void reportMemory(MemoryCounters& m) const override;
    const cluster::SurfaceOpenness* opennessTable() const override { return openness_; }

    /// Senders with more lit surfaces than this are represented by this
    /// many drawn by light (each surface pair costs a point-to-polygon form
    /// factor and a shadow ray per openness point).
    static constexpr uint32_t kSeenMaxSources = 64;
    /// Stand-ins whose receiver surfaces times sender surfaces exceed this
    /// stay by area.
    static constexpr uint64_t kSeenMaxPairs = 8192;

  private:
    struct SeenDecision;
    struct SeenScratch;
    /// newLinks for one cluster's fresh links: K / W (held to the bound),
    /// flags; returns how many were handed over by openness.
    uint64_t divideByOpenness(std::span<Link> links, const std::vector<uint64_t>& fresh,
                              const std::vector<double>& num, const std::vector<double>& den,
                              std::atomic<uint64_t>& capped) const;
    void seenCandidates(const HandOverLinks& h, uint32_t c, std::vector<SeenDecision>& out,
                        SeenScratch& s) const;
    double seenSources(const HandOverLinks& h, uint32_t r, uint32_t sender, SeenScratch& s) const;
    void scaleSeenWeights(uint32_t c, const SeenScratch& s, std::vector<SeenDecision>& out) const;
    void storeSeen(const HandOverLinks& h, std::vector<std::vector<SeenDecision>>& made);
    void clearSeen();

    const scene::Scene* scene_;
    const cluster::ClusterTree* tree_;
    uint32_t numPatches_;
    std::unique_ptr<cluster::SurfaceOpenness> owned_;
    const cluster::SurfaceOpenness* openness_;
    const transport::Visibility* seenVis_;
    uint64_t byOpenness_ = 0, byCosine_ = 0, capped_ = 0;
    /// Per cluster (tree index, +1), the range of its entries in seen_; each
    /// entry a stand-in (link index), the offset of its weights (one byte per
    /// surface below the cluster, in tree order, w_k scaled to 255) and the
    /// scale 255 W that turns a byte into w_k / W.
    struct SeenEntry {
        uint64_t link = 0;
        uint64_t weights = 0;
        float scale = 0.f;
    };
    std::vector<uint64_t> seenOffsets_;
    std::vector<SeenEntry> seen_;
    std::vector<uint8_t> seenWeights_;
    /// Every stand-in decided, by receiver << 32 | sender: its entry in
    /// seen_, or UINT64_MAX for by area.
    std::unordered_map<uint64_t, uint64_t> seenCache_;
    /// Position of each patch in the tree's order (made when first needed).
    std::vector<uint32_t> orderPos_;
};

/// The table row: traces the openness table (hr.seed draws its directions)
/// and, with cluster.stand_in_handover = seen, hands stand-ins over by what
/// each surface sees.
std::unique_ptr<HandOver> makeOpennessHandOver(const HandOverContext& ctx);

}  // namespace hrad::hr
