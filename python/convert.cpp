// Conversions between Python values and hrad's Params and JSON.
#include <fmt/format.h>
#include <pybind11/stl.h>

#include "core/error.h"
#include "python/bindings.h"

namespace hrad::python {

Params toParams(const py::dict& settings, const SourceLocation& where) {
    Params p;
    for (const auto& [k, v] : settings) {
        const std::string key = py::str(k);
        // bool before int: Python's True is an int too.
        if (py::isinstance<py::bool_>(v))
            p.set(key, v.cast<bool>(), where);
        else if (py::isinstance<py::int_>(v))
            p.set(key, v.cast<int64_t>(), where);
        else if (py::isinstance<py::float_>(v))
            p.set(key, v.cast<double>(), where);
        else if (py::isinstance<py::str>(v))
            p.set(key, v.cast<std::string>(), where);
        else
            throw InputError(where, fmt::format("setting '{}': a bool, int, float or str, not {}",
                                                key, std::string(py::str(v.get_type()))));
    }
    return p;
}

py::object toPython(const nlohmann::json& j) {
    // NaN and infinities are not JSON: dump() writes null, as summary.json has them.
    return py::module_::import("json").attr("loads")(j.dump());
}

const transport::Visibility& visibilityOf(SceneHandle& s) {
    if (!s.visibility) {
        py::gil_scoped_release release;
        s.visibility = std::make_shared<transport::Visibility>(*s.scene);
    }
    return *s.visibility;
}

}  // namespace hrad::python
