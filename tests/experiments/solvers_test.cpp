// The solver registry (experiments/solvers.h): names, errors for unknown
// names, and that a solve through the registry is the solver's own solve
// (same field, same counts), so the runner and `hrad solve` report the numbers
// they reported before the registry existed. Also the runner's pixel error
// against a path-traced image (render.error_reference = path-traced).
#include "experiments/solvers.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "experiments/runner.h"
#include "experiments/study.h"
#include "hr/solver.h"
#include "reference/fullmatrix.h"
#include "reference/metrics.h"
#include "reference/progressive.h"
#include "scene/loader.h"
#include "tests/test_util.h"
#include "transport/visibility.h"

namespace hrad::experiments {
namespace {

std::string studyErrorOf(const std::string& text) {
    try {
        validateStudy(parseStudy(text, "study.toml", "."));
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST(SolverRegistry, ListsTheRegisteredSolvers) {
    EXPECT_EQ(solverNames(), (std::vector<std::string>{"hr", "full-matrix", "progressive"}));
    for (const auto& n : solverNames()) {
        const SolverInfo* i = findSolver(n);
        ASSERT_NE(i, nullptr) << n;
        EXPECT_EQ(i->name, n);
        EXPECT_FALSE(i->description.empty()) << n;
        EXPECT_EQ(i->keepsHistory, !i->historyNote.empty()) << n;
    }
    EXPECT_EQ(findSolver("galerkin"), nullptr);
    EXPECT_TRUE(solverInfo("full-matrix").readsKey("fm.level"));
    EXPECT_FALSE(solverInfo("hr").readsKey("fm.level"));
    EXPECT_TRUE(solverInfo("progressive").readsKey("pr.max_shots"));
    EXPECT_FALSE(solverInfo("full-matrix").keepsHistory);
}

TEST(SolverRegistry, UnknownSolverInAStudyNamesFileLineAndTheValidNames) {
    std::string msg = studyErrorOf("scenes = [\"furnace\"]\n[solver]\nsolver = \"galerkin\"\n");
    EXPECT_NE(msg.find("study.toml:3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("galerkin"), std::string::npos) << msg;
    EXPECT_NE(msg.find("hr, full-matrix, progressive"), std::string::npos) << msg;
    // Also where a sweep axis names it (point 1 of 2).
    msg = studyErrorOf(
        "scenes = [\"furnace\"]\n[sweep]\nsolver = [\"hr\",\n \"hierarchical\"]\n");
    EXPECT_NE(msg.find("study.toml:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("hierarchical"), std::string::npos) << msg;
    EXPECT_NE(msg.find("point 1"), std::string::npos) << msg;
}

TEST(SolverRegistry, UnknownSolverWithoutStudyStillListsNames) {
    Params p;
    try {
        createSolver("southwell", p, SourceLocation{"command line (--solver)", 0, 0});
        FAIL() << "no error";
    } catch (const InputError& e) {
        std::string msg = e.what();
        EXPECT_NE(msg.find("--solver"), std::string::npos) << msg;
        EXPECT_NE(msg.find("progressive"), std::string::npos) << msg;
    }
}

TEST(SolverRegistry, BadSettingIsReportedByTheFactory) {
    Params p;
    p.set("pr.level", int64_t(-3), SourceLocation{"study.toml", 7, 1});
    try {
        createSolver("progressive", p);
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("study.toml:7"), std::string::npos) << e.what();
    }
}

/// Max relative difference of two fields' per-region averages (0 when equal).
double fieldDifference(const scene::RadiosityField& a, const scene::UniformField& b) {
    return reference::computeError(a, b).linfRgb;
}

class RegistryMatchesDirectCall : public ::testing::Test {
protected:
    Params none;
    scene::Scene sc = scene::loadScene("cornell", none);
    transport::Visibility vis{sc};
};

TEST_F(RegistryMatchesDirectCall, FullMatrix) {
    Params p;
    p.set("fm.level", int64_t(1), {});
    auto s = createSolver("full-matrix", p);
    SolveOutput out = s->solve(sc, vis, {});
    auto direct = reference::solveFullMatrix(sc, vis, reference::FullMatrixSettings::fromParams(p, "fm"),
                                             false);
    EXPECT_EQ(fieldDifference(*out.field, *direct.field), 0.0);
    EXPECT_EQ(out.summary.at("counts").at("elements").get<size_t>(), direct.stats.elements);
    EXPECT_EQ(out.summary.at("counts").at("iterations").get<int64_t>(), int64_t(direct.stats.iterations));
    EXPECT_EQ(out.memory.get("matrix"), direct.stats.matrixBytes);
    EXPECT_FALSE(out.summary.contains("history"));
}

TEST_F(RegistryMatchesDirectCall, ProgressiveWithHistoryError) {
    Params p;
    p.set("pr.level", int64_t(1), {});
    p.set("pr.history_every", int64_t(5), {});
    auto s = createSolver("progressive", p);
    reference::FullMatrixSettings refSettings;
    refSettings.level = 2;
    auto ref = reference::solveFullMatrix(sc, vis, refSettings, false);
    SolveContext ctx;
    int calls = 0;
    ctx.historyError = [&](const scene::RadiosityField& f) {
        ++calls;
        return reference::computeError(f, *ref.field).l2Lum;
    };
    SolveOutput out = s->solve(sc, vis, ctx);
    auto direct = reference::solveProgressive(
        sc, vis, reference::ProgressiveSettings::fromParams(p, "pr"), false);
    ASSERT_NE(out.field, nullptr);
    EXPECT_EQ(out.summary.at("counts").at("iterations").get<int64_t>(), direct.shots);
    EXPECT_EQ(out.summary.at("counts").at("elements").get<size_t>(), direct.elements);
    // The hook only reads the field: same answer with and without it.
    auto onDirect = reference::averageOnRegions(*direct.field, *ref.field);
    EXPECT_EQ(fieldDifference(*out.field, *onDirect), 0.0);
    const auto& hist = out.summary.at("history");
    ASSERT_EQ(hist.size(), direct.history.size());
    ASSERT_GT(calls, 0);
    EXPECT_EQ(size_t(calls), hist.size());
    // Every record carries the error, and shooting reduces it.
    for (const auto& h : hist) EXPECT_TRUE(h.at("l2_lum").is_number());
    EXPECT_LT(hist.back().at("l2_lum").get<double>(), hist.front().at("l2_lum").get<double>());
}

TEST_F(RegistryMatchesDirectCall, HierarchicalRadiosity) {
    Params p;
    p.set("oracle.eps", 1e-2, {});
    p.set("cluster.model", std::string("none"), {});
    auto s = createSolver("hr", p);
    SolveOutput out = s->solve(sc, vis, {});
    hr::HrSolver direct(sc, vis, hr::HrSettings::fromParams(p));
    hr::HrResult res = direct.solve(false);
    reference::FullMatrixSettings refSettings;
    refSettings.level = 2;
    auto ref = reference::solveFullMatrix(sc, vis, refSettings, false);
    auto onDirect = reference::averageOnRegions(*res.field, *ref.field);
    EXPECT_EQ(fieldDifference(*out.field, *onDirect), 0.0);
    EXPECT_EQ(out.summary.at("counts").at("links").get<size_t>(), res.hierarchy->numLinks());
    EXPECT_EQ(out.summary.at("history").size(), res.history.size());
    EXPECT_TRUE(out.timings.contains("refine"));
}

// ---- render.error_reference = path-traced (the pixel reference of final gather) ----
PointSpec coarseCornell(const std::string& reconstruction) {
    PointSpec p;
    p.scene = p.sceneLabel = "cornell";
    SourceLocation here{"study.toml", 4, 1};
    p.settings.set("solver", std::string("full-matrix"), here);
    p.settings.set("fm.level", int64_t(1), here);
    p.settings.set("render.reconstruction", reconstruction, here);
    p.settings.set("render.width", int64_t(48), here);
    p.settings.set("render.height", int64_t(48), here);
    p.settings.set("render.spp", int64_t(4), here);
    p.settings.set("render.error_reference", std::string("path-traced"), here);
    p.settings.set("render.reference_spp", int64_t(256), here);
    p.outputs.errorMap = true;
    return p;
}

// The final-gather image of a coarse solve is closer to a path-traced image
// of the same camera than the flat and the interpolated ones (the relative
// image L1 of the error map, sum |I - P| / sum |P| in luminance), and no
// reference solution is needed for the map. Same scene and sizes as
// FinalGather.CloserToPathTracedThanFlatAndInterpolated
// (tests/render/final_gather_test.cpp), here through the runner's error map.
TEST(ErrorReference, FinalGatherIsClosestToThePathTracedImage) {
    auto dir = test::tempDir("error_reference_pt");
    std::map<std::string, double> l1;
    for (std::string rec : {"flat", "interpolated", "final-gather"}) {
        RunContext ctx;
        ctx.artefactDir = dir / rec;
        auto s = runPoint(coarseCornell(rec), ctx);
        ASSERT_TRUE(s.contains("error_map")) << rec;
        EXPECT_EQ(s["error_map"]["reference"], "path-traced, 256 spp");
        EXPECT_EQ(s["error_map"]["mode"], "pixels");
        EXPECT_FALSE(s.contains("error")) << "no reference solution was asked for";
        EXPECT_TRUE(std::filesystem::exists(ctx.artefactDir / "reference.png"));
        EXPECT_TRUE(std::filesystem::exists(ctx.artefactDir / "error_fc.png"));
        l1[rec] = s["error_map"]["l1"].get<double>();
    }
    EXPECT_LT(l1["final-gather"], l1["flat"]);
    EXPECT_LT(l1["final-gather"], l1["interpolated"]);
}

TEST(ErrorReference, RegionsModeNeedsAReferenceSolution) {
    PointSpec p = coarseCornell("final-gather");
    p.settings.set("render.error_mode", std::string("regions"), SourceLocation{"study.toml", 9, 1});
    try {
        validatePoint(p);
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("study.toml:9"), std::string::npos) << e.what();
    }
    PointSpec q = coarseCornell("flat");
    q.settings.set("render.reference_spp", int64_t(65536), SourceLocation{"study.toml", 11, 1});
    try {
        validatePoint(q);
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("study.toml:11"), std::string::npos) << e.what();
    }
}

// ---- outputs.regions: the per-region comparison behind the error metrics ----
struct RegionRow {
    uint32_t patch = 0;
    double area = 0;
    RGB E{0.0}, S{0.0}, R{0.0};
    bool hasStdError = false;
};

std::vector<RegionRow> readRegions(const std::filesystem::path& csv) {
    std::ifstream in(csv);
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line.rfind("region,patch,element,material,area,", 0), 0u) << line;
    std::vector<RegionRow> rows;
    while (std::getline(in, line)) {
        std::vector<std::string> f;
        std::stringstream ss(line);
        for (std::string c; std::getline(ss, c, ',');) f.push_back(c);
        if (line.back() == ',') f.push_back("");
        EXPECT_EQ(f.size(), 17u) << line;
        if (f.size() != 17) break;
        RegionRow r;
        r.patch = uint32_t(std::stoul(f[1]));
        r.area = std::stod(f[4]);
        r.E = RGB(std::stod(f[5]), std::stod(f[6]), std::stod(f[7]));
        r.S = RGB(std::stod(f[8]), std::stod(f[9]), std::stod(f[10]));
        r.R = RGB(std::stod(f[11]), std::stod(f[12]), std::stod(f[13]));
        r.hasStdError = !f[14].empty();
        rows.push_back(r);
    }
    return rows;
}

PointSpec cornellAgainst(const std::string& kind) {
    PointSpec p;
    p.scene = p.sceneLabel = "cornell";
    SourceLocation here{"study.toml", 3, 1};
    p.settings.set("solver", std::string("hr"), here);
    p.settings.set("oracle.eps", 1e-2, here);
    p.reference.set("kind", kind, here);
    if (kind == "full-matrix") p.reference.set("fm.level", int64_t(2), here);
    if (kind == "montecarlo") {
        p.reference.set("mc.level", int64_t(0), here);
        p.reference.set("mc.samples", int64_t(64), here);
    }
    p.outputs.regions = true;
    return p;
}

// Every region of the reference gets one row, and the norms recomputed from
// the rows are the summary's: the file is what the metrics compared.
TEST(RegionsCsv, RowsAreWhatTheMetricsCompare) {
    auto dir = test::tempDir("regions_csv");
    for (std::string kind : {"full-matrix", "montecarlo"}) {
        RunContext ctx;
        ctx.artefactDir = dir / kind;
        ctx.useCache = false;
        auto s = runPoint(cornellAgainst(kind), ctx);
        ASSERT_TRUE(s["artefacts"].contains("regions")) << kind;
        std::vector<RegionRow> rows = readRegions(ctx.artefactDir / "regions.csv");
        ASSERT_EQ(rows.size(), s["error"]["regions"].get<size_t>()) << kind;
        double num1 = 0, den1 = 0, neS = 0, neR = 0;
        std::set<uint32_t> patches;
        for (const RegionRow& r : rows) {
            EXPECT_EQ(r.hasStdError, kind == "montecarlo");
            num1 += r.area * std::fabs(luminance(r.S) - luminance(r.R));
            den1 += r.area * std::fabs(luminance(r.R));
            if (maxComponent(r.E) == 0.0) {
                neS += r.area * luminance(r.S);
                neR += r.area * luminance(r.R);
            }
            patches.insert(r.patch);
        }
        EXPECT_EQ(patches.size(), s["scene_info"]["patches"].get<size_t>());
        EXPECT_NEAR(num1 / den1, s["error"]["l1_lum"].get<double>(), 1e-6) << kind;
        EXPECT_NEAR(neS / neR, s["error"]["mean_ratio_nonemitter"].get<double>(), 1e-6) << kind;
    }
}

TEST(RegionsCsv, NeedsAReference) {
    PointSpec p = cornellAgainst("none");
    p.outputs.regionsWhere = SourceLocation{"study.toml", 12, 1};
    try {
        validatePoint(p);
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("study.toml:12"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace hrad::experiments
