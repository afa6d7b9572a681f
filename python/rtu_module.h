// What the files of the extension _rtu share (rtu_module.cpp, rtu_queries.cpp, rtu_sweep.cpp): errors, Ctrl-C,
// JSON to Python, numpy arrays handed over, argument checks, and the registration functions of the bindings kept
// outside rtu_module.cpp. Only they include it.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <utility>
#include <vector>

#include "host/io/error.h"
#include "host/io/json_io.h"

namespace rtu::pymod {

namespace py = pybind11;

// An rtu.Error with `message` (host::Error, translated by the module).
[[noreturn]] inline void fail(const std::string& message) {
  throw host::Error(message);
}

// Ctrl-C during a long job: the host job calls this between its steps (SweepOptions::poll), on the calling thread
// with the GIL released. A pending signal runs its Python handler (SIGINT's raises KeyboardInterrupt), whose
// exception then unwinds the job and reaches the caller.
inline void check_signals() {
  py::gil_scoped_acquire gil;
  if (PyErr_CheckSignals() != 0) throw py::error_already_set();
}

// JSON to Python through the json module: the dict equals json.loads of the file rtusim writes.
inline py::object to_python(const host::Json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

// A job's thread count (0: all cores), refused when negative.
inline int check_threads(int threads) {
  if (threads < 0) fail("threads: " + std::to_string(threads) + " is negative (0: all cores)");
  return threads;
}

// A vector handed to numpy without a copy: the array owns it through a capsule.
template <class T>
py::array give(std::vector<T>&& v, const py::dtype& dt, std::vector<py::ssize_t> shape,
               std::vector<py::ssize_t> strides) {
  auto* owned = new std::vector<T>(std::move(v));
  py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array(dt, std::move(shape), std::move(strides), owned->data(), owner);
}

// The query and join bindings (rtu_queries.cpp).
void register_queries(py::module_& m);
// The sweep, manifest, plan and Pareto bindings (rtu_sweep.cpp), added to `m` after the others.
void register_sweep(py::module_& m);

}  // namespace rtu::pymod
