// The hand-over table (hr/handover.h): every transfer model names a row,
// and a hand-over registered as one class and one row is the one the
// solver makes and the push asks for shares.
#include "hr/handover.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <memory>

#include "cluster/link.h"
#include "cluster/transfer_model.h"
#include "hr/solver.h"
#include "scene/loader.h"
#include "transport/visibility.h"

using namespace hrad;

namespace {

/// What the test hand-over was asked.
struct Calls {
    std::atomic<uint64_t> flagged{0};     ///< links newLinks flagged
    std::atomic<uint64_t> batches{0};     ///< openShares calls
    std::atomic<uint64_t> shares{0};      ///< shares those calls gave
};

/// A trivial hand-over: every new link into a cluster is taken
/// (kOpenHandOver, K unchanged) and every surface is open (share = its
/// cosine), so the solve is the oriented model's by cosine alone, bit for bit.
class WholeHandOver final : public hr::HandOver {
  public:
    explicit WholeHandOver(std::shared_ptr<Calls> calls) : calls_(std::move(calls)) {}
    const char* name() const override { return "test_whole"; }
    void newLinks(const hr::HandOverLinks& h) override {
        for (uint32_t c = h.numPatches; c < h.numPatches + h.numClusters; ++c)
            for (uint64_t i = h.offsets[c]; i < h.offsets[c + 1]; ++i) {
                hr::Link& l = h.links[i];
                if ((l.flags & (hr::Link::kHandedOver | hr::Link::kStandIn)) || !(l.K > 0))
                    continue;
                l.flags |= hr::Link::kHandedOver | hr::Link::kOpenHandOver;
                ++calls_->flagged;
            }
    }
    void openShares(uint32_t, uint32_t, std::span<const glm::vec3> dirs,
                    std::span<double> w) const override {
        EXPECT_EQ(dirs.size(), w.size());
        ++calls_->batches;
        calls_->shares += w.size();
    }

  private:
    std::shared_ptr<Calls> calls_;
};

/// The oriented model in every respect but the hand-over it names.
class WholeModel final : public cluster::TransferModel {
  public:
    const char* name() const override { return "test_oriented_whole"; }
    double projectedFraction(const cluster::ClusterTree& tree, uint32_t c, double area,
                             const Vec3& d) const override {
        return oriented().projectedFraction(tree, c, area, d);
    }
    double maxProjectedFraction() const override { return oriented().maxProjectedFraction(); }
    Receive receives() const override { return oriented().receives(); }
    bool sendsByDirection() const override { return oriented().sendsByDirection(); }
    RGB sent(const cluster::ClusterTree& tree, uint32_t c, const cluster::RadiantMoments& m,
             const RGB& meanB, const Vec3& d) const override {
        return oriented().sent(tree, c, m, meanB, d);
    }
    const char* handOver(const cluster::ClusterLinkSettings&) const override {
        return "test_whole";
    }

  private:
    static const cluster::TransferModel& oriented() {
        return cluster::transferModel(cluster::ClusterModel::Oriented);
    }
};

/// Registers the row and the model once; the calls of every hand-over made.
std::shared_ptr<Calls> registered() {
    static const std::shared_ptr<Calls> calls = [] {
        auto c = std::make_shared<Calls>();
        hr::registerHandOver("test_whole", [c](const hr::HandOverContext&) {
            return std::make_unique<WholeHandOver>(c);
        });
        cluster::registerTransferModel("test_oriented_whole", std::make_unique<WholeModel>());
        return c;
    }();
    return calls;
}

hr::HrResult solve(const scene::Scene& s, const std::string& model, const std::string& handover) {
    Params p;
    p.set("hr.oracle", std::string("bfa"));
    p.set("oracle.eps", 1e-2);
    p.set("cluster.model", model);
    p.set("cluster.handover", handover);
    hr::HrSettings hs = hr::HrSettings::fromParams(p);
    p.reportUnused();
    transport::Visibility vis(s);
    return hr::HrSolver(s, vis, hs).solve();
}

}  // namespace

TEST(HandOver, TableRowsAndModelsNameThem) {
    registered();
    const std::vector<std::string> rows = hr::handOverNames();
    auto isRow = [&](const std::string& n) {
        return std::find(rows.begin(), rows.end(), n) != rows.end();
    };
    EXPECT_TRUE(isRow("none"));
    EXPECT_TRUE(isRow("openness"));
    EXPECT_TRUE(isRow("test_whole"));
    for (const std::string& m : cluster::clusterModelNames()) {
        const cluster::ClusterModel id = cluster::parseClusterModel(m);
        if (id == cluster::ClusterModel::Auto) continue;  // resolved to a model first
        for (bool visible : {true, false}) {
            cluster::ClusterLinkSettings cs;
            cs.visibleHandover = visible;
            const char* name = cluster::transferModel(id).handOver(cs);
            EXPECT_TRUE(isRow(name)) << "model " << m << " names hand-over " << name;
        }
    }
    cluster::ClusterLinkSettings visible, cosine;
    cosine.visibleHandover = false;
    const auto& oriented = cluster::transferModel(cluster::ClusterModel::Oriented);
    const auto& isotropic = cluster::transferModel(cluster::ClusterModel::Isotropic);
    EXPECT_STREQ(oriented.handOver(visible), "openness");
    EXPECT_STREQ(oriented.handOver(cosine), "none");
    EXPECT_STREQ(isotropic.handOver(visible), "none");
    EXPECT_STREQ(hr::makeHandOver("none", {})->name(), "none");
    EXPECT_THROW(hr::makeHandOver("no_such_hand_over", {}), Error);
}

TEST(HandOver, RegisteredHandOverIsWhatThePushUses) {
    const std::shared_ptr<Calls> calls = registered();
    const scene::Scene s = scene::loadScene("office:2");
    const hr::HrResult whole = solve(s, "test_oriented_whole", "visible");
    EXPECT_STREQ(whole.hierarchy->handOver().name(), "test_whole");
    EXPECT_FALSE(whole.openness);  // no openness table traced
    EXPECT_GT(calls->flagged.load(), 0u);
    EXPECT_GT(calls->batches.load(), 0u);
    EXPECT_GT(calls->shares.load(), calls->batches.load());
    // Every surface open: the oriented solve by cosine, bit for bit.
    const hr::HrResult cosine = solve(s, "oriented", "cosine");
    EXPECT_STREQ(cosine.hierarchy->handOver().name(), "none");
    const hr::Hierarchy &a = *whole.hierarchy, &b = *cosine.hierarchy;
    ASSERT_EQ(a.numElements(), b.numElements());
    ASSERT_EQ(a.numLinks(), b.numLinks());
    for (uint32_t e = 0; e < a.numElements(); ++e)
        ASSERT_EQ(std::memcmp(&a.B(e), &b.B(e), sizeof(RGB)), 0) << "element " << e;
    // And the openness row is what the oriented model names by default.
    const hr::HrResult open = solve(s, "oriented", "visible");
    EXPECT_STREQ(open.hierarchy->handOver().name(), "openness");
    ASSERT_TRUE(open.openness);
    EXPECT_GT(open.handOverByOpenness, 0u);
}
