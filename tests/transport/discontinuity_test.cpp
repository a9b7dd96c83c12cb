// Discontinuity meshing (transport/discontinuity.h) on closed forms: the
// umbra and penumbra of a square occluder under a square source parallel
// to the receiver (similar triangles), the scene unchanged with meshing off
// or without occluders, and the furnace exact on the cut scene.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>

#include "hr/hierarchy.h"
#include "reference/metrics.h"
#include "hr/solver.h"
#include "scene/loader.h"
#include "tests/hr/settings.h"
#include "tests/scenes.h"
#include "transport/discontinuity.h"
#include "transport/reachability.h"
#include "transport/visibility.h"

namespace hrad {
namespace {

scene::DiscontinuitySettings meshOn() {
    scene::DiscontinuitySettings d;
    d.mode = scene::DiscontinuitySettings::Mode::Emitters;
    return d;
}

// Receiver [-2,2]^2 at z = 0 facing +z; a black occluder [-b,b]^2 at z = ho
// facing down; a source [-a,a]^2 at z = hl facing down, E = 1.
scene::Scene squareShadow(double a, double b, double ho, double hl) {
    scene::Scene s;
    const uint32_t floor = s.addMaterial({"floor", RGB(0.5), RGB(0.0)});
    const uint32_t black = s.addMaterial({"occluder", RGB(0.0), RGB(0.0)});
    const uint32_t light = s.addMaterial({"light", RGB(0.0), RGB(1.0)});
    const Vec3 up(0, 0, 1), down(0, 0, -1);
    test::addQuadFacing(s, Vec3(-2, -2, 0), Vec3(2, -2, 0), Vec3(2, 2, 0), Vec3(-2, 2, 0), floor,
                        Vec3(0, 0, 1) + up);
    test::addQuadFacing(s, Vec3(-b, -b, ho), Vec3(b, -b, ho), Vec3(b, b, ho), Vec3(-b, b, ho), black,
                        Vec3(0, 0, ho) + down);
    test::addQuadFacing(s, Vec3(-a, -a, hl), Vec3(a, -a, hl), Vec3(a, a, hl), Vec3(-a, a, hl), light,
                        Vec3(0, 0, hl) + down);
    s.applyMaterials();
    return s;
}

// Which region of the shadow a floor point is in: outside the outer
// penumbra square (-1), else the cell of the 3 x 3 grid the lines
// x, y = -pen, -umb, umb, pen make inside it.
int region(const Vec3& p, double pen, double umb) {
    if (std::max(std::abs(p.x), std::abs(p.y)) > pen) return -1;
    auto cell = [&](double v) { return v < -umb ? 0 : (v > umb ? 2 : 1); };
    return 3 * cell(p.y) + cell(p.x);
}

// Heckbert 1992 / similar triangles: with the source at height hl, the
// occluder at ho and k = hl / (hl - ho), the line from source edge -a through
// occluder edge +b meets the floor at -a + (a + b) k (outer penumbra
// boundary), the line from +a through +b at a + (b - a) k (umbra boundary).
TEST(DiscontinuityMesh, CutsLieOnTheUmbraAndPenumbraBoundaries) {
    const double a = 0.25, b = 0.5, ho = 1.0, hl = 3.0, k = hl / (hl - ho);
    const double pen = -a + (a + b) * k, umb = a + (b - a) * k;  // 0.875, 0.625
    scene::Scene s = squareShadow(a, b, ho, hl);
    std::vector<uint32_t> origin;
    const scene::DiscontinuityStats st = transport::discontinuityMesh(s, meshOn(), origin);
    s.sourcePatch = origin;
    EXPECT_EQ(st.cutPatches, 1u);  // the floor; the occluder is black, the light unlit
    EXPECT_EQ(st.thin, 0u);
    double area = 0;
    for (uint32_t p = 0; p < s.patches.size(); ++p)
        if (origin[p] == 0) area += s.patches[p].area;
    EXPECT_NEAR(area, 16.0, 1e-12);
    // The cuts are the eight segments x, y = +-pen, +-umb across the outer
    // square (the umbra lines run on through the penumbra: where a source
    // vertex disappears behind the occluder, a D2 line). Then every piece
    // lies in one region (its corners, pulled 1e-9 towards its centroid,
    // classify the same), and the pieces of each region add up to the
    // region's area: a cut off its line by d would move about d x its
    // length of area between regions.
    EXPECT_EQ(st.faces, 10u);  // nine cells and the ring outside
    const double tol = 1e-9;   // the cuts are constructed in double from the corners
    std::map<int, double> regionArea;
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        if (origin[p] != 0) continue;
        const scene::Patch& t = s.patches[p];
        const Vec3 c = t.centroid();
        const int r = region(c, pen, umb);
        for (int k = 0; k < 3; ++k) {
            const Vec3 q = t.v[size_t(k)] + tol * (c - t.v[size_t(k)]);
            EXPECT_EQ(region(q, pen, umb), r) << "piece " << p << " straddles a boundary";
        }
        regionArea[r] += t.area;
    }
    const double w[3] = {pen - umb, 2 * umb, pen - umb};  // cell widths along x and y
    for (int iy = 0; iy < 3; ++iy)
        for (int ix = 0; ix < 3; ++ix)
            EXPECT_NEAR(regionArea[3 * iy + ix], w[ix] * w[iy], tol) << ix << ", " << iy;
    EXPECT_NEAR(regionArea[-1], 16.0 - 4 * pen * pen, tol);
}

// Off, the loaded scene is the plain loader's, to the bit.
TEST(DiscontinuityMesh, OffLeavesTheSceneUnchanged) {
    Params off;
    off.set("mesh.discontinuity", std::string("off"));
    const scene::Scene a = transport::loadScene("cornell", off);
    const scene::Scene b = scene::loadScene("cornell");
    ASSERT_EQ(a.patches.size(), b.patches.size());
    EXPECT_TRUE(a.sourcePatch.empty());
    for (size_t i = 0; i < a.patches.size(); ++i) {
        EXPECT_EQ(std::memcmp(&a.patches[i].v, &b.patches[i].v, sizeof(a.patches[i].v)), 0);
        EXPECT_EQ(a.patches[i].area, b.patches[i].area);
        EXPECT_EQ(a.patches[i].normal, b.patches[i].normal);
        EXPECT_EQ(a.patches[i].material, b.patches[i].material);
    }
    // And the plain loader refuses meshing rather than skipping it.
    Params on;
    on.set("mesh.discontinuity", std::string("emitters"));
    EXPECT_THROW(scene::loadScene("cornell", on), InputError);
}

// Receivers that see no occluder between them and the source get no cuts:
// the parallel plates, and the furnace box (every wall a source, nothing inside).
TEST(DiscontinuityMesh, NoOccluderNoCuts) {
    Params on;
    on.set("mesh.discontinuity", std::string("emitters+occluders"));
    for (const char* spec : {"plates:parallel:1:1:1", "furnace"}) {
        const scene::Scene s = transport::loadScene(spec, on);
        const scene::Scene plain = scene::loadScene(spec);
        EXPECT_GT(s.stats.discontinuity.pairs, 0u) << spec;
        EXPECT_EQ(s.stats.discontinuity.cutPatches, 0u) << spec;
        EXPECT_EQ(s.patches.size(), plain.patches.size()) << spec;
        EXPECT_TRUE(s.sourcePatch.empty()) << spec;
    }
}

// Cornell: the boxes shadow the floor and walls; the pieces of each patch
// add up to it and map back to it, back sides and all.
TEST(DiscontinuityMesh, PiecesMapBackToTheirPatches) {
    Params on;
    on.set("mesh.discontinuity", std::string("emitters"));
    const scene::Scene s = transport::loadScene("cornell", on);
    const scene::Scene plain = scene::loadScene("cornell");
    EXPECT_GT(s.stats.discontinuity.cutPatches, 0u);
    ASSERT_EQ(s.sourcePatch.size(), s.patches.size());
    EXPECT_EQ(s.numSourcePatches(), plain.patches.size());
    std::vector<double> area(plain.patches.size(), 0.0);
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        const uint32_t q = s.sourceOf(p);
        ASSERT_LT(q, plain.patches.size());
        EXPECT_EQ(s.patches[p].material, plain.patches[q].material);
        EXPECT_LT(glm::length(s.patches[p].normal - plain.patches[q].normal), 1e-12);
        area[q] += s.patches[p].area;
    }
    for (size_t q = 0; q < area.size(); ++q)
        EXPECT_NEAR(area[q], plain.patches[q].area, 1e-9 * plain.patches[q].area) << q;
    EXPECT_NEAR(luminance(s.emittedPower()), luminance(plain.emittedPower()),
                1e-12 * luminance(plain.emittedPower()));
}

// A furnace (every surface E = 1, rho = 0.5, closed) with a cube floating
// inside it (one-sided faces looking out): every patch is a source and the
// cube shadows the walls, so they are cut; every point still sees emitting
// surfaces of one reflectance all round, so B = E / (1 - rho) = 2 must hold
// on every leaf to the tolerance of the uncut furnace tests
// (tests/hr/solver_test.cpp, error oracle at eps 1e-3: reflected L1 per
// leaf < 0.5 %).
TEST(DiscontinuityMesh, FurnaceStaysExact) {
    scene::Scene s = test::furnaceBox(1.0, 0.5);
    const uint32_t m = s.patches[0].material;
    test::addBox(s, Vec3(0.35), Vec3(0.65), {m, m, m, m, m, m}, false);
    s.applyMaterials();
    std::vector<uint32_t> origin;
    const scene::DiscontinuityStats st = transport::discontinuityMesh(s, meshOn(), origin);
    EXPECT_GT(st.cutPatches, 0u);
    transport::Visibility vis(s);
    hr::HrSettings hs = test::hrSettings("error", 1e-3);
    hs.maxIterations = 400;
    hr::HrSolver solver(s, vis, hs);
    const hr::HrResult r = solver.solve();
    EXPECT_TRUE(r.converged);
    const hr::Hierarchy& h = *r.hierarchy;
    const double exact = 2.0;
    double l1 = 0, area = 0, worst = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (!h.isLeaf(e)) continue;
        double d = 0;
        for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(h.B(e)[c] - exact) / (exact - 1.0));
        l1 += h.area(e) * d;
        area += h.area(e);
        worst = std::max(worst, d);
    }
    l1 /= area;
    std::cout << "furnace with a block, " << st.cutPatches << " patches cut into " << st.pieces
              << " pieces: " << h.numLinks() << " links, reflected L1 " << l1 << ", worst "
              << worst << "\n";
    EXPECT_LT(l1, 0.005);
}

}  // namespace
}  // namespace hrad

namespace hrad {
namespace {

// error.by_source_patch merges a patch's pieces: a solution whose pieces are
// wrong but whose area-weighted mean over each original patch is right has
// no error per original patch, and a nonzero one per piece.
TEST(DiscontinuityMesh, SourcePatchErrorMergesPieces) {
    Params on;
    on.set("mesh.discontinuity", std::string("emitters"));
    const scene::Scene s = transport::loadScene("cornell", on);
    ASSERT_GT(s.stats.discontinuity.cutPatches, 0u);
    scene::UniformField ref(s, std::vector<uint8_t>(s.patches.size(), 0));
    scene::UniformField sol(s, std::vector<uint8_t>(s.patches.size(), 0));
    std::vector<int> seen(s.numSourcePatches(), -1);
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        ref.value(p) = s.patches[p].emission + RGB(0.3);
        sol.value(p) = ref.value(p);
        const uint32_t q = s.sourceOf(p);
        if (s.patches[p].isEmitter()) continue;
        if (seen[q] < 0) {
            seen[q] = int(p);  // the first piece of q takes +0.1, the second as much power less
        } else if (sol.value(uint32_t(seen[q])) == ref.value(uint32_t(seen[q]))) {
            const double a1 = s.patches[uint32_t(seen[q])].area, a2 = s.patches[p].area;
            sol.value(uint32_t(seen[q])) += RGB(0.1);
            sol.value(p) -= RGB(0.1 * a1 / a2);
        }
    }
    const reference::SourcePatchError merged = reference::computeSourcePatchError(sol, ref);
    EXPECT_EQ(merged.patches, s.numSourcePatches());
    EXPECT_LT(merged.l2NonEmitLum, 1e-12);
    EXPECT_GT(reference::computeError(sol, ref).l2NonEmitLum, 1e-2);
}

TEST(DiscontinuityMesh, UnknownModeIsAnInputError) {
    Params bad;
    bad.set("mesh.discontinuity", std::string("occluders"));
    try {
        (void)transport::loadScene("cornell", bad);
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("emitters+occluders"), std::string::npos) << e.what();
    }
}

// emitters+occluders: the largest reflectors cast curves too, so Cornell
// gets at least the cuts of emitters alone, and more.
TEST(DiscontinuityMesh, SecondarySourcesAddCuts) {
    Params a, b;
    a.set("mesh.discontinuity", std::string("emitters"));
    b.set("mesh.discontinuity", std::string("emitters+occluders"));
    const scene::Scene ea = transport::loadScene("cornell", a);
    const scene::Scene eb = transport::loadScene("cornell", b);
    EXPECT_EQ(eb.stats.discontinuity.sources, ea.stats.discontinuity.sources + 4);
    EXPECT_GT(eb.stats.discontinuity.curves, ea.stats.discontinuity.curves);
    EXPECT_GE(eb.stats.discontinuity.cutPatches, ea.stats.discontinuity.cutPatches);
}

}  // namespace
}  // namespace hrad
