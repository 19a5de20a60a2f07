#pragma once
// The parts of the extension module, one per file.
#include <pybind11/pybind11.h>

namespace burrbench::python {
void bind_files(pybind11::module_& m);        // validate(kind, path)
void bind_model(pybind11::module_& m);        // Volume, contact, replay
void bind_calibration(pybind11::module_& m);  // calibrate
}  // namespace burrbench::python
