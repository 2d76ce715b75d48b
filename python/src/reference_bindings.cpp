// _native._cpp_nearest_seconds: the C++ batch of python/src/reference_nearest.h run inside the
// binding's process, on the binding's own graph and queries, so that python/bench/bench_nearest.py
// can alternate it with nearest() and compare the two on the same memory.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <vector>

#include "bindings.h"
#include "reference_nearest.h"

namespace dw_py {

namespace py = pybind11;

void bindReference(py::module_& m) {
  m.def(
      "_cpp_nearest_seconds",
      [](const dw::NeighbourSearch& search, py::array_t<float, py::array::c_style | py::array::forcecast> q,
         unsigned threads, int repeats) {
        if (q.ndim() != 2 || q.shape(1) != 3) throw py::value_error("queries must be a (n, 3) array");
        if (repeats < 1) throw py::value_error("repeats must be >= 1");
        // The copy is the C++ user's own array, made before the clock starts.
        const std::vector<float> qs(q.data(), q.data() + q.size());
        ReferenceTiming t;
        {
          py::gil_scoped_release release;
          t = timeNearestBatch(search, qs.data(), qs.size() / 3, threads, repeats);
        }
        return py::make_tuple(t.seconds, t.cpu_seconds, t.index_sum);
      },
      py::arg("search"), py::arg("queries"), py::arg("threads") = 0, py::arg("repeats") = 1, R"doc(
For benchmarks: the fastest of `repeats` batches of nearest() written in C++ (KD-ANN start,
dw::parallelFor over the queries, input indices and squared distances out) on this search's graph:
(wall seconds, process CPU seconds, sum of the answers' indices).)doc");
}

}  // namespace dw_py
