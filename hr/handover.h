// The hand-over: how the light of a link into a receiving cluster reaches
// the surfaces below it, beyond what the transfer model's receives() says
// (cluster/transfer_model.h). Each model names the hand-over it uses
// (TransferModel::handOver); the solver makes it from the table in
// handover.cpp and gives it to the hierarchy (Hierarchy::setHandOver).
//
//   none      links hand their light over as the model receives it: by
//             area (isotropic) or by each surface's cosine (oriented);
//   openness  (oriented, cluster.handover = visible) by cosine times each
//             surface's openness towards the sender, and, with
//             cluster.stand_in_handover = seen, stand-ins that no direction
//             hands over by what each surface sees of the sender
//             (hr/openness_handover.h; Smits, Arvo & Greenberg 1994 sec. 4
//             hand over by cosine; openness and seen are hrad's).
//
// The hierarchy keeps the links and their flags: a hand-over flags the links
// it takes (Link::kOpenHandOver; Link::bySeen for stand-ins) when setLinks()
// first sees them (newLinks, standIns), and the push asks it for the share
// of each flagged link every surface takes (openShares, forEachSurfaceShare).
// A new hand-over is one class and one row (registerHandOver for tests).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "core/memory.h"
#include "core/types.h"
#include "hr/hierarchy.h"

namespace hrad::cluster {
class ClusterTree;
class SurfaceOpenness;
struct ClusterLinkSettings;
}  // namespace hrad::cluster
namespace hrad::transport {
class Visibility;
}

namespace hrad::hr {

/// The part of the hierarchy a hand-over works on when links are set
/// (Hierarchy::setLinks), valid for that call only.
struct HandOverLinks {
    uint32_t numPatches = 0, numClusters = 0;
    std::span<const uint32_t> offsets;  ///< CSR row starts per node
    std::span<Link> links;              ///< K and flags may be changed
    /// Unit direction from receiver to sender of every link in the cluster
    /// rows (receivesByCosine models; zero for a by-area stand-in), from
    /// link dirBase on; empty without such links.
    std::span<const glm::vec3> dirs;
    uint64_t dirBase = 0;
    std::span<const uint32_t> patchOf;  ///< root patch of each node (kNone: cluster)
    std::span<const RGB> B;             ///< radiosity of each node
    bool hasStandIns = false;           ///< some link has Link::kStandIn
    uint64_t seed = 0;                  ///< Hierarchy::setSeed
    bool isCluster(uint32_t e) const { return e >= numPatches && e < numPatches + numClusters; }
};

/// A non-owning callable f(link index, share), for the shares a hand-over
/// hands the push without a std::function's allocation.
class ShareFn {
  public:
    template <class F>
        requires(!std::is_same_v<std::remove_cvref_t<F>, ShareFn>)
    ShareFn(F&& f)  // NOLINT: implicit, as a lambda is passed
        : obj_(const_cast<void*>(static_cast<const void*>(&f))),
          call_([](void* o, uint64_t i, double w) { (*static_cast<std::remove_reference_t<F>*>(o))(i, w); }) {}
    void operator()(uint64_t i, double w) const { call_(obj_, i, w); }

  private:
    void* obj_;
    void (*call_)(void*, uint64_t, double);
};

class HandOver {
  public:
    virtual ~HandOver() = default;
    /// The lowercase name of its table row.
    virtual const char* name() const = 0;
    /// setLinks: links into clusters not decided before get their hand-over
    /// (K, flags).
    virtual void newLinks(const HandOverLinks& h) { (void)h; }
    /// setLinks, after newLinks: stand-ins that no direction hands over.
    virtual void standIns(const HandOverLinks& h) { (void)h; }
    /// Links into cluster node c flagged Link::kOpenHandOver that light
    /// root patch `root` (below c) from unit directions dirs[f] (receiver
    /// to sender): w[f] holds the patch's cosine towards dirs[f] (> 0) and
    /// receives its share per unit of what the link sends. The push asks
    /// in batches, in link order.
    virtual void openShares(uint32_t c, uint32_t root, std::span<const glm::vec3> dirs,
                            std::span<double> w) const {
        (void)c, (void)root, (void)dirs, (void)w;
    }
    /// Calls f(i, w) for each stand-in i into cluster node c handed over by
    /// what each surface sees (Link::bySeen) that gives root patch `root`
    /// the share w > 0 of what it sends, in a fixed order.
    virtual void forEachSurfaceShare(uint32_t c, uint32_t root, ShareFn f) const {
        (void)c, (void)root, (void)f;
    }
    /// For such a stand-in i into cluster node c: sum_k A_k rho_k w_k over
    /// the surfaces below c (what it sends times this is the power they
    /// reflect); nullopt for a link it does not hand over.
    virtual std::optional<RGB> surfaceReflected(uint32_t c, uint64_t i) const {
        (void)c, (void)i;
        return std::nullopt;
    }
    /// The summary's counters (summary.json handover_*).
    struct Counts {
        uint64_t byOpenness = 0;  ///< links into clusters by cosine and openness
        uint64_t byCosine = 0;    ///< ... by cosine alone (no surface open)
        uint64_t capped = 0;      ///< of those by openness, K / W held to the bound
        uint64_t seen = 0;        ///< stand-ins by what each surface sees, now
    };
    virtual Counts counts() const { return {}; }
    virtual void reportMemory(MemoryCounters& m) const { (void)m; }
    /// The openness table it traced (cluster/openness.h), or null.
    virtual const cluster::SurfaceOpenness* opennessTable() const { return nullptr; }
};

/// What a table row makes its hand-over from (the solver's).
struct HandOverContext {
    const scene::Scene* scene = nullptr;
    const cluster::ClusterTree* tree = nullptr;
    const transport::Visibility* visibility = nullptr;
    const cluster::ClusterLinkSettings* settings = nullptr;
    uint64_t seed = 0;      ///< hr.seed
    bool progress = false;  ///< progress bars on stderr
};
using HandOverFactory = std::function<std::unique_ptr<HandOver>(const HandOverContext&)>;

/// The table's row names, in order.
std::vector<std::string> handOverNames();
/// The hand-over of row `name`; an unknown name is an error listing the rows.
std::unique_ptr<HandOver> makeHandOver(const std::string& name, const HandOverContext& ctx);
/// Test hook: adds a row (a lowercase name not yet taken). A hand-over of
/// the library is a row of the table in handover.cpp.
void registerHandOver(const std::string& name, HandOverFactory factory);

}  // namespace hrad::hr
