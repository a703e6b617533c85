// SPDX-License-Identifier: Apache-2.0
// Python bindings of the native tracer: the only file that includes nanobind.
#include <nanobind/nanobind.h>
#include <thread>

namespace nb = nanobind;

NB_MODULE(_native, m) {
    m.doc() = "phongscene native ray tracer (C++17)";
    m.def("hardware_threads", [] { return std::thread::hardware_concurrency(); },
          "Number of hardware threads the tracer uses when threads=0.");
}
