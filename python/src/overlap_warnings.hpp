#pragma once
// Warnings about the data (two recordings of one sample that removed the same bone, the
// alignment's warnings: model::alignment_warnings) as Python warnings: the CLI
// prints them on stderr, a script gets a UserWarning it can filter or turn into an error.
// Call with the GIL held, after the work.
#include <string>
#include <vector>

#include <pybind11/pybind11.h>

#include "burrbench/model/experiment.hpp"

namespace burrbench::python {

inline void warn(const std::string& text) {
  if (PyErr_WarnEx(PyExc_UserWarning, text.c_str(), 1) != 0) throw pybind11::error_already_set();
}

inline void warn_overlaps(const std::vector<model::RemovedOverlap>& overlaps) {
  for (const model::RemovedOverlap& o : overlaps) warn(o.text());
}

}  // namespace burrbench::python
