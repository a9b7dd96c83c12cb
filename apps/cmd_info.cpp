#include <fmt/format.h>

#include <cstdio>

#include "apps/commands.h"
#include "core/memory.h"
#include "scene/coplanar.h"
#include "scene/loader.h"
#include "transport/reachability.h"

namespace hrad::app {

namespace {
/// The non-area lights (scene/lights/light.h): describe(), which names the
/// kind and its parameters (an envmap's file, size, scale and mean
/// radiance), the power each sends into the scene's bounding sphere (max
/// channel, the oracles' power scale), and whether the random walks draw it
/// by next-event estimation (importance-sampled).
void printLights(const scene::Scene& s) {
    if (s.lights.empty()) return;
    const double R = 0.5 * s.bounds().diagonal();
    fmt::print("lights         {} non-area (power: into the bounding sphere, max channel)\n",
               s.lights.size());
    for (const auto& l : s.lights)
        fmt::print("  {}; power {:.6g} W{}\n", l->describe(), l->power(R),
                   l->importanceSampled() ? "; importance-sampled" : "");
}
}  // namespace

int runInfo(const std::string& spec, Params& params) {
    scene::Scene s = transport::loadScene(spec, params);
    params.reportUnused();
    const auto& st = s.stats;
    scene::Bounds3 b = s.bounds();
    RGB power = s.emittedPower();
    fmt::print("scene          {}\n", s.name);
    fmt::print("source         {}\n", s.source);
    fmt::print("patches        {} ({} triangles, {} quads)\n", s.patches.size(),
               s.count(scene::PatchKind::Triangle), s.count(scene::PatchKind::Quad));
    if (size_t twins = s.numBackSides())
        fmt::print(
            "two-sided      {} patches have a back-side twin (counted above, and twice in "
            "the area)\n",
            twins);
    fmt::print("input faces    {}\n", st.inputFaces);
    fmt::print("triangulated   {} faces\n", st.triangulatedFaces);
    fmt::print("dropped        {} degenerate faces\n", st.droppedDegenerate);
    if (st.splitCandidates > 0)
        fmt::print(
            "split          {} of the {} patches passing through or touching others, where "
            "light would leak, into {} triangles\n",
            st.splitPatches, st.splitCandidates, st.splitPieces);
    else
        fmt::print("split          {} patches passing through others, into {} triangles\n",
                   st.splitPatches, st.splitPieces);
    if (st.discontinuity.sources > 0)
        fmt::print(
            "discontinuity  {} of {} patches cut along {} shadow-boundary segments into {} "
            "triangles ({} sources)\n",
            st.discontinuity.cutPatches, s.numSourcePatches(), st.discontinuity.curves,
            st.discontinuity.pieces, st.discontinuity.sources);
    if (st.defaultMaterialFaces)
        fmt::print("default mat.   {} faces had no material\n", st.defaultMaterialFaces);
    if (st.ignoredStatements) fmt::print("ignored        {} statements\n", st.ignoredStatements);
    {
        scene::CoplanarOverlaps ov(s);
        if (!ov.empty())
            fmt::print(
                "stacked faces  {} pairs of coplanar overlapping faces; {} patches are hidden "
                "in part (the emitting, else the smaller, face is in front: scene/coplanar.h)\n",
                ov.numPairs(), ov.numHiddenPatches());
        if (ov.numSheetPairs())
            fmt::print(
                "sheets         {} pairs of overlapping faces in one plane facing opposite ways; "
                "each sees its own side (transport/visibility.h)\n",
                ov.numSheetPairs());
    }
    fmt::print("emitters       {} patches\n", s.numEmitters());
    fmt::print("total area     {:.6g}\n", s.totalArea());
    fmt::print("emitted power  ({:.6g}, {:.6g}, {:.6g})  [E * area, RGB]\n", power.r, power.g,
               power.b);
    printLights(s);
    fmt::print("bounds         ({:.6g}, {:.6g}, {:.6g}) .. ({:.6g}, {:.6g}, {:.6g})\n", b.lo.x,
               b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
    if (s.camera)
        fmt::print(
            "camera         eye ({:.4g}, {:.4g}, {:.4g}) target ({:.4g}, {:.4g}, {:.4g}) fov "
            "{:.4g}\n",
            s.camera->eye.x, s.camera->eye.y, s.camera->eye.z, s.camera->target.x,
            s.camera->target.y, s.camera->target.z, s.camera->fovYDegrees);
    if (s.camera && s.camera->filmWidth > 0) {
        static const char* kAxis[] = {"x", "y", "diagonal", "smaller", "larger"};
        fmt::print("film           {} x {} (fov axis {}; the default image size)\n",
                   s.camera->filmWidth, s.camera->filmHeight, kAxis[int(s.camera->fovAxis)]);
    }
    fmt::print("load time      {:.3f} s\n", st.loadSeconds);
    fmt::print("peak RSS       {}\n", formatBytes(peakRssBytes()));

    // Materials with the number of patches using each.
    std::vector<size_t> uses(s.materials.size(), 0);
    std::vector<double> area(s.materials.size(), 0.0);
    for (const auto& p : s.patches) {
        ++uses[p.material];
        area[p.material] += p.area;
    }
    fmt::print("materials      {}\n", s.materials.size());
    fmt::print("  {:<28} {:>8} {:>12}  {:<26} {}\n", "name", "patches", "area", "rho", "E");
    for (size_t m = 0; m < s.materials.size(); ++m) {
        const auto& mat = s.materials[m];
        fmt::print(
            "  {:<28} {:>8} {:>12.5g}  ({:.3f}, {:.3f}, {:.3f})    ({:.4g}, {:.4g}, {:.4g})\n",
            mat.name, uses[m], area[m], mat.rho.r, mat.rho.g, mat.rho.b, mat.emission.r,
            mat.emission.g, mat.emission.b);
    }
    for (const auto& w : st.warnings) fmt::print("warning        {}\n", w);
    return 0;
}

}  // namespace hrad::app
