// The module _gpu of the package pcl_delaunay_walk: the CUDA module (gpu/, dw::gpu::DelaunayWalk and
// dw::gpu::IterativeClosestPoint) from NumPy. A separate extension from _native, so that the CPU
// package imports where the CUDA runtime library is missing; pcl_delaunay_walk.gpu imports it when it
// can and raises RuntimeError otherwise. Every entry point checks for a CUDA device first and raises
// RuntimeError naming what the runtime said, never touching the device without one.
#include <cuda_runtime_api.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "arrays.h"
#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/gpu/delaunay_walk.h"
#include "pcl_delaunay_walk/gpu/device_buffer.h"
#include "pcl_delaunay_walk/gpu/iterative_closest_point.h"

namespace py = pybind11;

namespace {

/// "" when a CUDA device can be used, else why not (the runtime's own words).
std::string whyNoDevice() {
  int n = 0;
  const cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    cudaGetLastError();  // clear the sticky error so a later call does not report it again
    return std::string("no CUDA device: ") + cudaGetErrorString(e);
  }
  if (n == 0) return "no CUDA device: the CUDA runtime sees 0 devices";
  return "";
}

void requireDevice(const char* what) {
  const std::string why = whyNoDevice();
  if (!why.empty()) throw std::runtime_error(std::string("pcl_delaunay_walk.gpu.") + what + ": " + why);
}

/// The graph on the device, with the host graph it came from kept alive (indices, origin).
struct GpuWalk {
  std::shared_ptr<const dw::DelaunayGraph> graph;
  std::shared_ptr<dw::gpu::DelaunayWalk> walk;
};

GpuWalk makeWalk(std::shared_ptr<dw::DelaunayGraph> g) {
  if (!g) throw py::type_error("gpu.DelaunayWalk needs a DelaunayGraph, got None");
  requireDevice("DelaunayWalk");
  GpuWalk w;
  w.graph = std::move(g);
  py::gil_scoped_release release;
  w.walk = std::make_shared<dw::gpu::DelaunayWalk>(*w.graph);
  return w;
}

/// Caller points (any float layout) as a PointView, copying only when the layout needs it.
dw::PointView viewOf(dw_py::Points& p) {
  return dw_py::pointView(p);
}

py::tuple nearest(const GpuWalk& w, py::handle queries, py::handle hints_obj) {
  dw_py::Points q = dw_py::pointsArg(queries, "queries");
  const bool have_hints = !hints_obj.is_none();
  const py::array_t<std::int64_t> hints =
      have_hints ? dw_py::hintsArg(hints_obj, q.n) : py::array_t<std::int64_t>();
  const dw::PointView view = viewOf(q);
  const auto n = static_cast<py::ssize_t>(q.n);
  py::array_t<std::int64_t> indices(n), ends(n);
  py::array_t<float> dist2(n);
  std::int64_t* idx = indices.mutable_data();
  std::int64_t* end = ends.mutable_data();
  float* d2 = dist2.mutable_data();
  const std::int64_t* h = have_hints ? hints.data() : nullptr;
  if (q.n == 0) return py::make_tuple(indices, dist2, ends);  // no device transfer for an empty batch
  {
    py::gil_scoped_release release;
    std::vector<float4> local;
    w.walk->toLocal(view, local);
    std::vector<std::uint32_t> start(q.n);
    for (std::size_t i = 0; i < q.n; ++i) start[i] = h ? dw_py::hintVertex(h[i]) : dw::kInvalidIndex;
    dw::gpu::DeviceBuffer<float4> dq;
    dw::gpu::DeviceBuffer<std::uint32_t> dh, dv;
    dw::gpu::DeviceBuffer<float> dd;
    dq.upload(local);
    if (h) dh.upload(start);
    w.walk->nearest(dq, h ? &dh : nullptr, dv, dd);
    std::vector<std::uint32_t> v;
    std::vector<float> dist;
    dv.download(v);
    dd.download(dist);
    const auto& rep = w.walk->vertexToInput();
    for (std::size_t i = 0; i < q.n; ++i) {
      const bool ok = v[i] < rep.size();
      idx[i] = ok ? std::int64_t(rep[v[i]]) : -1;
      d2[i] = ok ? dist[i] : std::numeric_limits<float>::infinity();
      end[i] = ok ? std::int64_t(v[i]) : (h ? h[i] : -1);
    }
  }
  return py::make_tuple(indices, dist2, ends);
}

py::dict icp(py::handle source, const GpuWalk& target, py::object init, int max_iterations,
             double max_distance, double transformation_epsilon, double fitness_epsilon) {
  requireDevice("icp");
  if (max_iterations < 1) throw py::value_error("max_iterations must be at least 1");
  dw_py::Points src = dw_py::pointsArg(source, "source");
  const dw::PointView view = viewOf(src);
  dw::gpu::Matrix4d guess = dw::gpu::identityMatrix4d();
  if (!init.is_none()) {
    const py::array_t<double, py::array::c_style | py::array::forcecast> a =
        py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(init);
    if (!a || a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
      throw py::value_error("init must be a 4x4 matrix");
    for (int k = 0; k < 16; ++k) guess[k] = a.data()[k];
  }
  dw::gpu::IcpParameters p;
  p.max_iterations = max_iterations;
  if (!std::isinf(max_distance)) p.max_correspondence_distance = max_distance;
  p.transformation_epsilon = transformation_epsilon;
  if (!std::isinf(fitness_epsilon)) p.euclidean_fitness_epsilon = fitness_epsilon;
  dw::gpu::IcpResult r;
  {
    py::gil_scoped_release release;
    dw::gpu::IterativeClosestPoint reg(target.walk);
    reg.setParameters(p);
    reg.setInputSource(view);
    r = reg.align(guess);
  }
  py::array_t<double> t({4, 4});
  for (int k = 0; k < 16; ++k) t.mutable_data()[k] = r.transformation[k];
  py::dict d;
  d["transform"] = t;
  d["iterations"] = r.iterations;
  d["converged"] = r.converged;
  d["state"] = dw::gpu::toString(r.state);
  d["mse"] = r.mse;
  d["correspondences"] = r.correspondences;
  return d;
}

}  // namespace

PYBIND11_MODULE(_gpu, m) {
  m.doc() = "pcl_delaunay_walk CUDA module: the GPU Delaunay walk and ICP (use pcl_delaunay_walk.gpu)";
  py::module_::import("pcl_delaunay_walk._native");  // registers DelaunayGraph for the arguments below
  m.def("why_unavailable", &whyNoDevice, "'' when a CUDA device can be used, else the reason.");
  py::class_<GpuWalk>(m, "DelaunayWalk", R"doc(
The graph uploaded to the current CUDA device for exact batch nearest-neighbour search (keeps the
host graph alive). Raises RuntimeError without a CUDA device.)doc")
      .def(py::init(&makeWalk), py::arg("graph"))
      .def_property_readonly("num_vertices", [](const GpuWalk& w) { return w.walk->numVertices(); })
      .def("nearest", &nearest, py::arg("queries"), py::arg("hints") = py::none(), R"doc(
Exact nearest neighbour of each query on the GPU: (indices int64, sq_dists float32, ends int64), as
NeighbourSearch.nearest; pass `ends` back as `hints`.)doc");
  const double inf = std::numeric_limits<double>::infinity();
  m.def("icp", &icp, py::arg("source"), py::arg("target"), py::arg("init") = py::none(),
        py::arg("max_iterations") = 50, py::arg("max_distance") = inf,
        py::arg("transformation_epsilon") = 0.0, py::arg("fitness_epsilon") = -inf, R"doc(
Point-to-point ICP of source onto target (a gpu.DelaunayWalk) entirely on the GPU, with PCL's
convergence rules: {'transform' 4x4 float64, 'iterations', 'converged', 'state', 'mse',
'correspondences'}.)doc");
}
