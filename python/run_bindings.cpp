// The module's functions around runs: the log level (`hrad --log`), the
// settings reference (`hrad settings`), the results store's checks before pandas reads it
// (experiments/store.h), and a study's validation before `hrad sweep` runs it.
#include <pybind11/stl.h>

#include "core/log.h"
#include "experiments/settings_reference.h"
#include "experiments/store.h"
#include "experiments/study.h"
#include "python/bindings.h"

namespace hrad::python {

void bindRuns(py::module_& m) {
    initLogging("info");  // the command line's format, on stderr
    m.def("log_level", &initLogging, py::arg("level"), R"doc(
The log's level on stderr: "quiet" (warnings only), "info" (the default) or
"debug"; the command line's --log.)doc");
    m.def(
        "settings_help",
        [](const std::string& prefix) {
            return experiments::settingsText(experiments::settingsReference(), prefix);
        },
        py::arg("prefix") = "", R"doc(
Every setting key with its default, type, range, reader and doc: the text of
`hrad settings PREFIX` (the command line's own keys aside).)doc");
    m.def(
        "_check_store",
        [](const std::string& path) {
            experiments::ResultStore store(path, /*readOnly=*/true);
            return store.schemaVersion();
        },
        py::arg("path"));
    m.def(
        "_validate_study",
        [](const std::string& path) {
            experiments::Study study = experiments::loadStudy(path);
            experiments::validateStudy(study);
            py::dict d;
            d["name"] = study.name;
            d["points"] = study.pointCount();
            return d;
        },
        py::arg("path"));
}

}  // namespace hrad::python
