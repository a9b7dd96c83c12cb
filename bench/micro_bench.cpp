// Micro-benchmarks: form factors and the gather/push-pull sweep.
// Run: ./build/bench/hrad_micro_bench  (results in bench/results/micro.md)
#include <benchmark/benchmark.h>

#include "hr/solver.h"
#include "scene/loader.h"
#include "transport/formfactor.h"

using namespace hrad;

static void BM_PointToPolygon(benchmark::State& state) {
    Vec3 quad[4] = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    Vec3 p(0.3, 0.2, 0.0), n(0, 0, 1);
    double sum = 0;
    for (auto _ : state) {
        sum += transport::pointToPolygon(p, n, quad, 4);
        benchmark::DoNotOptimize(sum);
        p.x += 1e-9;
    }
}
BENCHMARK(BM_PointToPolygon);

static void BM_ElementFormFactor(benchmark::State& state) {
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    transport::FormFactorSettings fs;
    fs.visRays = int(state.range(0));
    transport::FormFactorEngine eng(s, &vis, fs);
    transport::ElementRef a{0, scene::keyDomain(s.patches[0].kind, 21), 1};
    uint32_t other = 1;
    while (!eng.facing(a, {other, {}, 2})) ++other;
    transport::ElementRef b{other, scene::keyDomain(s.patches[other].kind, 22), 2};
    for (auto _ : state) {
        auto r = eng.compute(a, b);
        benchmark::DoNotOptimize(r);
        a.id++;
    }
}
BENCHMARK(BM_ElementFormFactor)->Arg(0)->Arg(4)->Arg(16);

// A near pair: two unit squares meeting at a right angle (shared edge), no
// visibility rays, with ff.adaptive_depth = N (0: the fixed 3x3 rule; 3: the
// full matrix's default, which refines the receiver rule towards the edge).
static void BM_NearPairFormFactor(benchmark::State& state) {
    scene::Scene s;
    uint32_t m = s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    s.addQuad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), m);
    s.addQuad(Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(0, 1, 1), Vec3(0, 0, 1), m);
    transport::FormFactorSettings fs;
    fs.visRays = 0;
    fs.adaptiveDepth = int(state.range(0));
    transport::FormFactorEngine eng(s, nullptr, fs);
    transport::ElementRef a{0, {}, 1}, b{1, {}, 2};
    double F = 0;
    for (auto _ : state) {
        auto r = eng.compute(a, b);
        F = r.F;
        benchmark::DoNotOptimize(r);
    }
    state.counters["F"] = F;
}
BENCHMARK(BM_NearPairFormFactor)->Arg(0)->Arg(3);

static void BM_GatherPushPull(benchmark::State& state) {
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    Params p;
    p.set("oracle.eps", 1e-4);
    p.set("hr.max_iterations", int64_t(3));
    hr::HrSolver solver(s, vis, hr::HrSettings::fromParams(p));
    hr::HrResult r = solver.solve();
    for (auto _ : state) {
        r.hierarchy->gather();
        r.hierarchy->pushPull();
    }
    state.counters["links"] = double(r.hierarchy->numLinks());
    state.counters["links/s"] = benchmark::Counter(double(r.hierarchy->numLinks()),
                                                   benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_GatherPushPull)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
