// The Python module `hrad` (pybind11): what its C++ files share. Thin over
// the C++ API: every computation is the one `hrad solve`, `hrad reference`,
// `hrad render` and `hrad sweep` run (experiments/runner.h, reference/,
// render/); this folder only converts arguments and results.
//
// Objects:
//   SceneHandle  a loaded scene (transport::loadScene) with the spec and the
//                loader settings it was loaded with, its patches as numpy
//                arrays, and its visibility structure built on first need;
//   Solution     a RadiosityField with what keeps it alive (the solver's
//                hierarchy, the scene), its summary (summary.json's dict),
//                per-leaf and per-patch arrays.
// Long calls run through runInterruptible (python/interrupt.h): the GIL is
// released and Ctrl-C stops an hr solve (core/cancel.h, hr/budget.h).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <pybind11/pybind11.h>

#include "core/params.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::python {

namespace py = pybind11;

struct SceneHandle {
    std::string spec;                    ///< what loadScene received
    py::dict settings;                   ///< the loader settings it was loaded with
    std::shared_ptr<const scene::Scene> scene;
    std::shared_ptr<const transport::Visibility> visibility;  ///< built by visibilityOf
    py::dict arrays;                     ///< patch arrays, made on first access
};

struct Solution {
    std::shared_ptr<SceneHandle> scene;
    const scene::RadiosityField* field = nullptr;
    std::shared_ptr<const void> owner;  ///< keeps *field alive
    py::object summary = py::none();    ///< dict (summary.json) or None
    std::vector<RGB> stdError;          ///< Monte Carlo reference: per region
    py::dict arrays;                    ///< leaf and patch arrays, made on first access
};

/// A Python dict {key: bool | int | float | str} as Params, every entry at
/// `where` (the caller's file:line, so an unknown key names it).
Params toParams(const py::dict& settings, const SourceLocation& where);
/// JSON as Python objects (dict, list, float, ...).
py::object toPython(const nlohmann::json& j);
/// The scene's visibility structure, built once (GIL released).
const transport::Visibility& visibilityOf(SceneHandle& scene);

void bindScene(py::module_& m);
void bindSolution(py::module_& m);
void bindRuns(py::module_& m);

}  // namespace hrad::python
