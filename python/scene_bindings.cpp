// hrad.Scene and hrad.load: a scene loaded by transport::loadScene (built-in
// names and every format, the loader settings of `hrad settings`), its root
// patches as numpy arrays. Patches are stored as structs (scene/scene.h), so
// each array is one copy, made on first access and then shared (read-only).
#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "python/bindings.h"
#include "python/interrupt.h"
#include "transport/reachability.h"

namespace hrad::python {

namespace {

using Array = py::array_t<double>;

py::array readOnly(py::array a) {
    a.attr("setflags")(py::arg("write") = false);
    return a;
}

/// Per-patch arrays: (P, 4, 3) vertices (a triangle repeats its third), the
/// vertex count, normal, area, rho, E, material index, twin (-1: none).
py::dict patchArrays(const scene::Scene& sc) {
    const py::ssize_t n = py::ssize_t(sc.patches.size());
    Array vertices({n, py::ssize_t(4), py::ssize_t(3)}), normal({n, py::ssize_t(3)}),
        area(n), rho({n, py::ssize_t(3)}), emission({n, py::ssize_t(3)});
    py::array_t<int32_t> count(n), material(n);
    py::array_t<int64_t> twin(n);
    auto v = vertices.mutable_unchecked<3>();
    auto nr = normal.mutable_unchecked<2>(), r = rho.mutable_unchecked<2>(),
         e = emission.mutable_unchecked<2>();
    auto a = area.mutable_unchecked<1>();
    auto c = count.mutable_unchecked<1>(), m = material.mutable_unchecked<1>();
    auto t = twin.mutable_unchecked<1>();
    for (py::ssize_t i = 0; i < n; ++i) {
        const scene::Patch& p = sc.patches[size_t(i)];
        for (int k = 0; k < 4; ++k)
            for (int d = 0; d < 3; ++d) v(i, k, d) = p.v[size_t(k)][d];
        for (int d = 0; d < 3; ++d) {
            nr(i, d) = p.normal[d];
            r(i, d) = p.rho[d];
            e(i, d) = p.emission[d];
        }
        a(i) = p.area;
        c(i) = p.numVertices();
        m(i) = int32_t(p.material);
        t(i) = p.twin == UINT32_MAX ? -1 : int64_t(p.twin);
    }
    py::dict out;
    out["vertices"] = readOnly(vertices);
    out["vertex_count"] = readOnly(count);
    out["normal"] = readOnly(normal);
    out["area"] = readOnly(area);
    out["rho"] = readOnly(rho);
    out["E"] = readOnly(emission);
    out["material"] = readOnly(material);
    out["twin"] = readOnly(twin);
    return out;
}

py::object patchArray(SceneHandle& s, const char* name) {
    if (s.arrays.empty()) s.arrays = patchArrays(*s.scene);
    return s.arrays[name];
}

std::shared_ptr<SceneHandle> load(const std::string& spec, const py::dict& settings,
                                  const std::string& file, int line) {
    auto handle = std::make_shared<SceneHandle>();
    handle->spec = spec;
    handle->settings = settings;
    Params params = toParams(settings, {file, line, 0});
    runInterruptible([&](CancelToken&) {
        handle->scene = std::make_shared<scene::Scene>(transport::loadScene(spec, params));
        params.reportUnused();
    });
    return handle;
}

}  // namespace

void bindScene(py::module_& m) {
    py::class_<SceneHandle, std::shared_ptr<SceneHandle>> cls(m, "Scene", R"doc(
A loaded scene: root patches (triangles, planar quads) with materials and emitters.

Made by hrad.load(). Patch arrays (numpy, read-only, one row per root patch):
vertices (P, 4, 3) (a triangle repeats its third vertex), vertex_count (P,),
normal (P, 3), area (P,), rho (P, 3), E (P, 3) (emitted radiosity, W/m^2),
material (P,) (index into materials), twin (P,) (the other side of a
two-sided surface, -1 for none).)doc");
    cls.def_readonly("spec", &SceneHandle::spec, "what was loaded: a built-in name or a path")
        .def_readonly("settings", &SceneHandle::settings, "the loader settings it was loaded with")
        .def_property_readonly("name", [](const SceneHandle& s) { return s.scene->name; })
        .def_property_readonly("num_patches",
                               [](const SceneHandle& s) { return s.scene->patches.size(); })
        .def_property_readonly("materials",
                               [](const SceneHandle& s) {
                                   std::vector<std::string> names;
                                   for (const auto& mat : s.scene->materials)
                                       names.push_back(mat.name);
                                   return names;
                               },
                               "material names, indexed by the material array")
        .def_property_readonly("total_area",
                               [](const SceneHandle& s) { return s.scene->totalArea(); })
        .def("__len__", [](const SceneHandle& s) { return s.scene->patches.size(); })
        .def("__repr__", [](const SceneHandle& s) {
            return fmt::format("<hrad.Scene '{}': {} patches, {} emitters>", s.spec,
                               s.scene->patches.size(), s.scene->numEmitters());
        });
    for (const char* name :
         {"vertices", "vertex_count", "normal", "area", "rho", "E", "material", "twin"})
        cls.def_property_readonly(name,
                                  [name](SceneHandle& s) { return patchArray(s, name); });
    m.def("_load", &load, py::arg("spec"), py::arg("settings"), py::arg("file"),
          py::arg("line"));
}

}  // namespace hrad::python
