// What a new cluster transfer model costs: one class and one registry row
// (cluster/transfer_model.h, registerTransferModel), nothing in hr/.
#include "cluster/transfer_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>

#include "cluster/isotropic_model.h"
#include "hr/solver.h"
#include "tests/hr/settings.h"
#include "tests/scenes.h"

using namespace hrad;

namespace {
/// A trivial model written from scratch: every cluster looks like a
/// quarter of its area from everywhere and its surfaces take what it
/// receives alike (the isotropic model's physics, in a class of its own).
class QuarterModel final : public cluster::TransferModel {
  public:
    const char* name() const override { return "test_quarter"; }
    double projectedFraction(const cluster::ClusterTree&, uint32_t, double,
                             const Vec3&) const override {
        return 0.25;
    }
    double maxProjectedFraction() const override { return 0.25; }
    Receive receives() const override { return Receive::ByArea; }
};

cluster::ClusterModel quarter() {
    static const cluster::ClusterModel id =
        cluster::registerTransferModel("test_quarter", std::make_unique<QuarterModel>());
    return id;
}

hr::HrResult solve(const scene::Scene& s, const std::string& model, const std::string& oracle,
                   double eps) {
    transport::Visibility vis(s);
    hr::HrSolver solver(s, vis, test::hrSettings(oracle, eps, model));
    return solver.solve();
}
}  // namespace

TEST(TransferModel, RegisteredModelIsARowOfTheTable) {
    const cluster::ClusterModel id = quarter();
    EXPECT_EQ(cluster::parseClusterModel("test_quarter"), id);
    EXPECT_STREQ(cluster::clusterModelName(id), "test_quarter");
    EXPECT_STREQ(cluster::transferModel(id).name(), "test_quarter");
    const auto names = cluster::clusterModelNames();
    EXPECT_NE(std::find(names.begin(), names.end(), "test_quarter"), names.end());
    EXPECT_THROW(cluster::parseClusterModel("no_such_model"), InputError);
}

// The uniform oracle opens every cluster: the furnace's exact answer
// E / (1 - rho) = 2 on every leaf.
TEST(TransferModel, RegisteredModelSolvesTheFurnace) {
    quarter();
    const scene::Scene s = test::furnaceBox(1.0, 0.5);
    const hr::HrResult r = solve(s, "test_quarter", "uniform", 0);
    EXPECT_TRUE(r.converged);
    ASSERT_TRUE(r.clusterTree);
    EXPECT_EQ(r.clusterModel, "test_quarter");
    const hr::Hierarchy& h = *r.hierarchy;
    EXPECT_GT(h.numClusters(), 0u);
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (h.isLeaf(e)) {
            EXPECT_NEAR(h.B(e).g, 2.0, 2e-3);
        }
    }
}

// With the isotropic model's physics the registered model gives the
// isotropic solve bit for bit on a clustered scene with links kept at
// cluster level (bfa at a loose eps).
TEST(TransferModel, RegisteredModelMatchesIsotropicBitForBit) {
    quarter();
    const scene::Scene s = test::furnaceBox(1.0, 0.5);
    const hr::HrResult a = solve(s, "test_quarter", "bfa", 1e-2);
    const hr::HrResult b = solve(s, "isotropic", "bfa", 1e-2);
    const hr::Hierarchy &ha = *a.hierarchy, &hb = *b.hierarchy;
    ASSERT_EQ(ha.numElements(), hb.numElements());
    ASSERT_EQ(ha.numLinks(), hb.numLinks());
    for (uint32_t e = 0; e < ha.numElements(); ++e)
        EXPECT_EQ(std::memcmp(&ha.B(e), &hb.B(e), sizeof(RGB)), 0) << "element " << e;
}
