// hrad.Solution and what makes or reads one: hrad.solve (experiments::runPoint,
// the code `hrad solve` and every sweep point run), hrad.reference
// (experiments::prepareReference, `hrad reference`, with its cache),
// hrad.read_solution (reference::loadSolution, `hrad render`'s reader),
// hrad.error (reference::computeError, the summary's error block) and
// hrad.render (render::renderField, `hrad render`'s image).
#include <optional>

#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "experiments/runner.h"
#include "python/bindings.h"
#include "python/interrupt.h"
#include "reference/cache.h"
#include "reference/metrics.h"
#include "render/render.h"
#include "scene/basis.h"
#include "scene/element.h"

namespace hrad::python {

namespace {

using nlohmann::json;

py::array readOnly(py::array a) {
    a.attr("setflags")(py::arg("write") = false);
    return a;
}

/// One row per leaf: patch, key, level, corners (L, 4, 3; a triangle repeats
/// its third), area, B (the leaf's mean, RGB) and the basis coefficients
/// after the mean (L, n - 1, 3; n = 1 for piecewise constant fields).
py::dict leafArrays(const scene::RadiosityField& f) {
    const scene::Scene& sc = f.scene();
    struct Row {
        uint32_t patch;
        scene::ElementKey key;
        RGB b;
    };
    std::vector<Row> rows;
    for (uint32_t p = 0; p < sc.patches.size(); ++p)
        f.forEachLeaf(p, [&](scene::ElementKey k, const RGB& b) { rows.push_back({p, k, b}); });
    const py::ssize_t n = py::ssize_t(rows.size());
    const int higher = scene::basisSize(f.basisDegree()) - 1;
    py::array_t<int32_t> patch(n), level(n);
    py::array_t<uint64_t> key(n);
    py::array_t<double> corners({n, py::ssize_t(4), py::ssize_t(3)}), area(n),
        b({n, py::ssize_t(3)}), coeff({n, py::ssize_t(higher), py::ssize_t(3)});
    auto pa = patch.mutable_unchecked<1>(), lv = level.mutable_unchecked<1>();
    auto ky = key.mutable_unchecked<1>();
    auto co = corners.mutable_unchecked<3>(), cf = coeff.mutable_unchecked<3>();
    auto ar = area.mutable_unchecked<1>();
    auto bb = b.mutable_unchecked<2>();
    std::vector<RGB> c(size_t(std::max(higher, 1)));
    for (py::ssize_t i = 0; i < n; ++i) {
        const Row& r = rows[size_t(i)];
        const scene::Patch& p = sc.patches[r.patch];
        const scene::Domain d = scene::keyDomain(p.kind, r.key);
        Vec3 pts[4];
        const int m = scene::elementCorners(p, d, pts);
        for (int k = 0; k < 4; ++k)
            for (int j = 0; j < 3; ++j) co(i, k, j) = pts[k < m ? k : m - 1][j];
        pa(i) = int32_t(r.patch);
        ky(i) = r.key;
        lv(i) = scene::keyLevel(r.key);
        ar(i) = scene::elementArea(p, d);
        for (int j = 0; j < 3; ++j) bb(i, j) = r.b[j];
        if (higher > 0) f.leafHigherCoefficients(r.patch, r.key, c.data());
        for (int h = 0; h < higher; ++h)
            for (int j = 0; j < 3; ++j) cf(i, h, j) = c[size_t(h)][j];
    }
    py::dict out;
    out["patch"] = readOnly(patch);
    out["key"] = readOnly(key);
    out["level"] = readOnly(level);
    out["corners"] = readOnly(corners);
    out["area"] = readOnly(area);
    out["B"] = readOnly(b);
    out["coefficients"] = readOnly(coeff);
    return out;
}

/// Per root patch: the field's exact area-weighted average (key 1, the root).
py::array patchAverages(const scene::RadiosityField& f) {
    const py::ssize_t n = py::ssize_t(f.scene().patches.size());
    py::array_t<double> b({n, py::ssize_t(3)});
    auto bb = b.mutable_unchecked<2>();
    for (py::ssize_t p = 0; p < n; ++p) {
        const RGB v = f.average(uint32_t(p), scene::ElementKey(1));
        for (int j = 0; j < 3; ++j) bb(p, j) = v[j];
    }
    return readOnly(b);
}

py::object solutionArray(Solution& s, const std::string& name) {
    if (s.arrays.empty()) {
        s.arrays = leafArrays(*s.field);
        s.arrays["patch_B"] = patchAverages(*s.field);
    }
    return s.arrays[name.c_str()];
}

std::shared_ptr<SceneHandle> handleFor(const experiments::RunOutput& run,
                                       const std::shared_ptr<SceneHandle>& given) {
    auto h = std::make_shared<SceneHandle>();
    h->spec = given->spec;
    h->settings = given->settings;
    h->scene = run.scene;
    h->visibility = run.visibility;
    return h;
}

std::shared_ptr<Solution> solutionOf(const experiments::RunOutput& run, const json& summary,
                                     const std::shared_ptr<SceneHandle>& given) {
    auto s = std::make_shared<Solution>();
    s->scene = handleFor(run, given);
    s->field = run.solved.field;
    s->owner = run.solved.owner;
    s->stdError = run.stdError;
    s->summary = toPython(summary);
    return s;
}

experiments::PointSpec pointFor(const SceneHandle& scene, const py::dict& settings,
                                const py::dict& reference, bool historyError,
                                const SourceLocation& where) {
    experiments::PointSpec point;
    point.scene = scene.spec;
    point.sceneLabel = scene.spec;
    point.settings = toParams(settings, where);
    point.reference = toParams(reference, where);
    point.outputs.historyError = historyError;  // no files: the solution stays in memory
    return point;
}

/// SolveContext::onRecord for a Python callable, called on the solve's
/// thread with the GIL: the first exception it raises is kept and stops the
/// solve (the token), to be raised by solve() once the solve has unwound.
struct RecordCallback {
    py::object fn;
    std::optional<py::error_already_set> raised;

    void operator()(const json& record, CancelToken& token) {
        py::gil_scoped_acquire gil;
        if (raised) return;
        try {
            fn(toPython(record));
        } catch (py::error_already_set& e) {
            raised.emplace(std::move(e));
            token.request();
        }
    }
};

std::shared_ptr<Solution> solve(const std::shared_ptr<SceneHandle>& scene,
                                const py::dict& settings, const py::dict& reference,
                                bool historyError, const py::object& onIteration, bool progress,
                                bool cache, const std::string& cacheDir, const std::string& file,
                                int line) {
    experiments::PointSpec point =
        pointFor(*scene, settings, reference, historyError, {file, line, 0});
    experiments::RunOutput kept;
    json summary;
    RecordCallback callback{onIteration, {}};
    try {
        runInterruptible([&](CancelToken& token) {
            experiments::RunContext ctx;
            ctx.progress = progress;
            ctx.useCache = cache;
            ctx.cacheDir = cacheDir;
            ctx.cancel = &token;
            ctx.keep = [&](const experiments::RunOutput& r) { kept = r; };
            if (!onIteration.is_none())
                ctx.onRecord = [&](const json& r) { callback(r, token); };
            summary = experiments::runPoint(point, ctx);
        });
    } catch (const Cancelled&) {
        if (!callback.raised) throw;
    }
    if (callback.raised) throw *callback.raised;
    return solutionOf(kept, summary, scene);
}

std::shared_ptr<Solution> computeReference(const std::shared_ptr<SceneHandle>& scene,
                                           const py::dict& settings, const py::dict& reference,
                                           bool progress, bool cache, const std::string& cacheDir,
                                           const std::string& file, int line) {
    experiments::PointSpec point = pointFor(*scene, settings, reference, false, {file, line, 0});
    experiments::RunOutput kept;
    json description;
    runInterruptible([&](CancelToken&) {
        experiments::validatePoint(point);  // unknown keys, as `hrad reference`
        experiments::RunContext ctx;
        ctx.progress = progress;
        ctx.useCache = cache;
        ctx.cacheDir = cacheDir;
        ctx.keep = [&](const experiments::RunOutput& r) { kept = r; };
        description = experiments::prepareReference(point, ctx);
    });
    if (!kept.solved.field)
        throw InputError({file, line, 0}, "hrad.reference: kind = \"none\" computes nothing");
    return solutionOf(kept, description, scene);
}

std::shared_ptr<Solution> readSolution(const std::string& path,
                                       const std::shared_ptr<SceneHandle>& scene) {
    auto s = std::make_shared<Solution>();
    s->scene = scene;
    std::shared_ptr<const scene::LeafField> field = reference::loadSolution(path, *scene->scene);
    s->field = field.get();
    s->owner = field;
    return s;
}

py::object error(const Solution& solution, const Solution& ref) {
    const auto* uniform = dynamic_cast<const scene::UniformField*>(ref.field);
    if (!uniform)
        throw Error(
            "hrad.error: the reference must be a uniform field (hrad.reference, or a "
            "full-matrix solve)");
    json e = experiments::errorMetricsJson(reference::computeError(*solution.field, *uniform));
    return toPython(e);
}

py::array render(Solution& s, const py::dict& settings, const std::string& file, int line) {
    Params params = toParams(settings, {file, line, 0});
    render::RenderSettings rs = render::RenderSettings::fromParams(params, "render");
    rs.adoptFilm(*s.scene->scene);
    params.reportUnused();
    const transport::Visibility& vis = visibilityOf(*s.scene);
    auto img = std::make_unique<render::Image>();
    runInterruptible([&](CancelToken&) {
        scene::Camera cam = render::chooseCamera(*s.scene->scene, vis, rs);
        *img = render::renderField(*s.scene->scene, vis, *s.field, cam, rs);
    });
    // The pixels are row-major dvec3 (render/image.h): an H x W x 3 view, no copy.
    const py::ssize_t w = img->width, h = img->height;
    double* data = &img->pixels.data()->x;
    py::capsule free(img.release(), [](void* p) { delete static_cast<render::Image*>(p); });
    return py::array_t<double>({h, w, py::ssize_t(3)}, data, free);
}

}  // namespace

void bindSolution(py::module_& m) {
    py::class_<Solution, std::shared_ptr<Solution>> cls(m, "Solution", R"doc(
A radiosity solution (hrad.solve, hrad.reference, hrad.read_solution).

summary: the dict of summary.json (hrad.solve), the reference's description
(hrad.reference) or None (hrad.read_solution).
Per leaf (numpy, read-only, one row per leaf element, patch by patch):
patch, key (quadtree key, scene/element.h), level, corners (L, 4, 3),
area, B (L, 3: mean radiosity RGB), coefficients (L, n-1, 3: polynomial
basis coefficients after the mean, hr.basis; n-1 = 0 for constant fields).
Per root patch: patch_B (P, 3), the exact area-weighted averages.)doc");
    cls.def_readonly("summary", &Solution::summary)
        .def_readonly("scene", &Solution::scene)
        .def_property_readonly("num_leaves",
                               [](Solution& s) { return py::len(solutionArray(s, "patch")); })
        .def_property_readonly("basis_degree", [](const Solution& s) { return s.field->basisDegree(); })
        .def_property_readonly("power",
                               [](const Solution& s) {
                                   RGB p = s.field->totalPower();
                                   return std::vector<double>{p.r, p.g, p.b};
                               },
                               "total radiosity power, sum over leaves of B A (RGB)")
        .def_property_readonly("std_error",
                               [](const Solution& s) -> py::object {
                                   if (s.stdError.empty()) return py::none();
                                   py::array_t<double> a({py::ssize_t(s.stdError.size()), py::ssize_t(3)});
                                   auto v = a.mutable_unchecked<2>();
                                   for (size_t k = 0; k < s.stdError.size(); ++k)
                                       for (int j = 0; j < 3; ++j) v(py::ssize_t(k), j) = s.stdError[k][j];
                                   return readOnly(a);
                               },
                               "Monte Carlo reference: standard error per region (RGB), else None")
        .def("save",
             [](const Solution& s, const std::filesystem::path& path) {
                 reference::saveSolution(path.string(), *s.field);
             },
             py::arg("path"), "writes the solution as a .hrsol file (hrad render reads it)")
        .def("__repr__", [](const Solution& s) {
            return fmt::format("<hrad.Solution of '{}'>", s.scene->spec);
        });
    for (const char* name :
         {"patch", "key", "level", "corners", "area", "B", "coefficients", "patch_B"})
        cls.def_property_readonly(name, [name](Solution& s) { return solutionArray(s, name); });
    m.def("_solve", &solve);
    m.def("_reference", &computeReference);
    m.def("_read_solution", &readSolution);
    m.def("_error", &error);
    m.def("_render", &render);
}

}  // namespace hrad::python
