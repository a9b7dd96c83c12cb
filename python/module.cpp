// PYBIND11_MODULE(_hrad): the compiled part of the `hrad` package
// (python/hrad/__init__.py is the public face and holds the docstrings of
// the functions). hrad's exceptions become Python exceptions carrying the
// same text as the CLI's message: hrad.InputError (a ValueError) for bad
// input, "FILE:LINE: error: ..."; hrad.Error (a RuntimeError) for the rest;
// hrad::Cancelled (core/cancel.h) is a KeyboardInterrupt.
#include "core/cancel.h"
#include "core/error.h"
#include "python/bindings.h"

namespace py = pybind11;

PYBIND11_MODULE(_hrad, m) {
    m.doc() = "hrad's compiled bindings; use the `hrad` package";
    // InputError is an hrad.Error and a ValueError.
    static PyObject* error = PyErr_NewException("hrad.Error", PyExc_RuntimeError, nullptr);
    static PyObject* inputError = PyErr_NewException(
        "hrad.InputError", py::make_tuple(py::handle(error), py::handle(PyExc_ValueError)).ptr(),
        nullptr);
    m.attr("Error") = py::handle(error);
    m.attr("InputError") = py::handle(inputError);
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const hrad::Cancelled& e) {
            PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
        } catch (const hrad::InputError& e) {
            PyErr_SetString(inputError, e.what());
        } catch (const hrad::Error& e) {
            PyErr_SetString(error, e.what());
        }
    });
    hrad::python::bindScene(m);
    hrad::python::bindSolution(m);
    hrad::python::bindRuns(m);
}
