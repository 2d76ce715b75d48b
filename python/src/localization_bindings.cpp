// Localizer and SlidingWindowOdometry: dw::Localizer (a prior map's walk graph, built once) and
// dw::SlidingWindowOdometry (a DynamicDelaunayGraph local map) from NumPy scans, and their per-frame
// FrameResult. Scans are registered with the GIL released. Each object carries a mutex taken with the
// GIL released, so concurrent calls from Python threads queue up instead of racing on the track.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "arrays.h"
#include "bindings.h"
#include "pcl_delaunay_walk/core/registration/localizer.h"
#include "pcl_delaunay_walk/core/registration/sliding_window_odometry.h"

namespace dw_py {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// The ICP keywords shared by both classes, checked here so that a bad value is a ValueError naming
/// the keyword before any map is built.
struct IcpArgs {
  std::string method = "point_to_point";
  double max_distance = 1.0;
  int max_iterations = 30;
  double transformation_epsilon = 1e-8;
  double fitness_epsilon = -kInf;
  std::string kernel = "none";
  double kernel_scale = 1.0;

  dw::IcpOptions options() const {
    dw::IcpOptions o;
    if (method == "point_to_point")
      o.metric = dw::IcpMetric::PointToPoint;
    else if (method == "point_to_plane")
      o.metric = dw::IcpMetric::PointToPlane;
    else
      throw py::value_error("method must be 'point_to_point' or 'point_to_plane', got '" + method + "'");
    if (kernel == "none")
      o.kernel = dw::RobustKernel::None;
    else if (kernel == "huber")
      o.kernel = dw::RobustKernel::Huber;
    else if (kernel == "cauchy")
      o.kernel = dw::RobustKernel::Cauchy;
    else
      throw py::value_error("kernel must be 'none', 'huber' or 'cauchy', got '" + kernel + "'");
    if (!(max_distance > 0)) throw py::value_error("max_distance must be positive");
    if (max_iterations < 1) throw py::value_error("max_iterations must be at least 1");
    if (!(transformation_epsilon >= 0)) throw py::value_error("transformation_epsilon must be >= 0");
    if (!(kernel_scale > 0) || std::isinf(kernel_scale))
      throw py::value_error("kernel_scale must be positive");
    if (std::isnan(fitness_epsilon)) throw py::value_error("fitness_epsilon must not be NaN");
    o.max_correspondence_distance = max_distance;
    o.max_iterations = max_iterations;
    o.transformation_epsilon = transformation_epsilon;
    // -inf means "off", which PCL and dw::IcpOptions spell -max.
    o.euclidean_fitness_epsilon = std::isinf(fitness_epsilon) && fitness_epsilon < 0
                                      ? -std::numeric_limits<double>::max()
                                      : fitness_epsilon;
    o.kernel_scale = kernel_scale;
    return o;
  }
};

Eigen::Matrix4d poseArg(py::handle obj, const char* name) {
  const py::array a = py::array::ensure(obj);
  if (!a || a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
    throw py::value_error(std::string(name) + " must be a 4x4 matrix");
  const Eigen::Matrix4d m = py::cast<Eigen::Matrix4d>(obj);
  if (!m.allFinite()) throw py::value_error(std::string(name) + " must be finite");
  return m;
}

/// A tracker (dw::Localizer, dw::SlidingWindowOdometry) that Python threads may share: each call into
/// it runs without the GIL and one at a time.
template <class Tracker>
class SharedTracker {
 public:
  /// Registers a scan, from `init` instead of the prediction when it is not None (set_pose first).
  dw::FrameResult registerScan(py::handle scan, py::handle init) {
    Points p = pointsArg(scan, "scan");
    const dw::PointView view = pointView(p);
    const bool set = !init.is_none();
    const Eigen::Matrix4d start = set ? poseArg(init, "init") : Eigen::Matrix4d::Identity();
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(mutex_);
    if (set) tracker_->setPose(start);
    return tracker_->registerScan(view);
  }

  void setPose(py::handle pose) {
    const Eigen::Matrix4d m = poseArg(pose, "pose");
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(mutex_);
    tracker_->setPose(m);
  }

  template <typename F>
  auto locked(F&& f) {
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(mutex_);
    return f(*tracker_);
  }

 protected:
  std::unique_ptr<Tracker> tracker_;

 private:
  std::mutex mutex_;
};

class PyLocalizer : public SharedTracker<dw::Localizer> {
 public:
  PyLocalizer(py::handle map, const IcpArgs& icp, double voxel, bool constant_velocity, double min_fitness,
              double max_rmse, std::size_t normal_k, bool warm_start, unsigned threads) {
    dw::LocalizerOptions o;
    o.icp = icp.options();
    o.voxel = voxel;
    o.constant_velocity = constant_velocity;
    o.min_fitness = min_fitness;
    o.max_rmse = max_rmse;
    if (normal_k < 3) throw py::value_error("normal_k must be at least 3");
    if (!(min_fitness >= 0 && min_fitness <= 1)) throw py::value_error("min_fitness must be in [0, 1]");
    if (!(voxel >= 0) || std::isinf(voxel)) throw py::value_error("voxel must be >= 0 and finite");
    if (std::isnan(max_rmse)) throw py::value_error("max_rmse must not be NaN");
    o.normal_neighbours = normal_k;
    o.warm_start_across_frames = warm_start;
    o.num_threads = threads;
    if (py::isinstance<dw::DelaunayGraph>(map)) {
      const auto graph = map.cast<std::shared_ptr<dw::DelaunayGraph>>();
      py::gil_scoped_release release;
      tracker_ = std::make_unique<dw::Localizer>(dw::DelaunayGraph(*graph), o);
    } else if (py::isinstance<py::str>(map) || py::hasattr(map, "__fspath__")) {
      const std::string path = py::str(py::module_::import("os").attr("fspath")(map));
      py::gil_scoped_release release;
      tracker_ = std::make_unique<dw::Localizer>(dw::Localizer::load(path, o));
    } else {
      Points p = pointsArg(map, "map");
      const dw::PointView view = pointView(p);
      py::gil_scoped_release release;
      tracker_ = std::make_unique<dw::Localizer>(view, o);
    }
  }
};

class PyOdometry : public SharedTracker<dw::SlidingWindowOdometry> {
 public:
  PyOdometry(const IcpArgs& icp, double voxel, double max_range, unsigned max_age, double min_fitness,
             unsigned threads) {
    dw::OdometryOptions o;
    o.icp = icp.options();
    o.voxel = voxel;
    o.max_range = max_range;
    o.max_age = max_age;
    o.min_fitness = min_fitness;
    o.num_threads = threads;
    if (!(min_fitness >= 0 && min_fitness <= 1)) throw py::value_error("min_fitness must be in [0, 1]");
    if (!(voxel > 0) || std::isinf(voxel)) throw py::value_error("voxel must be positive and finite");
    if (!(max_range > 0)) throw py::value_error("max_range must be positive");
    tracker_ = std::make_unique<dw::SlidingWindowOdometry>(o);
  }
};

void bindFrameResult(py::module_& m) {
  py::enum_<dw::FrameStatus>(m, "FrameStatus", "What became of one frame (dw::FrameStatus).")
      .value("Ok", dw::FrameStatus::Ok)
      .value("EmptyScan", dw::FrameStatus::EmptyScan)
      .value("NoFinitePoints", dw::FrameStatus::NoFinitePoints)
      .value("NoCorrespondences", dw::FrameStatus::NoCorrespondences)
      .value("LostTrack", dw::FrameStatus::LostTrack);
  py::enum_<dw::IcpConvergence>(m, "IcpConvergence", "Why the ICP loop stopped (dw::IcpConvergence).")
      .value("NotConverged", dw::IcpConvergence::NotConverged)
      .value("Iterations", dw::IcpConvergence::Iterations)
      .value("Transform", dw::IcpConvergence::Transform)
      .value("AbsoluteMse", dw::IcpConvergence::AbsoluteMse)
      .value("RelativeMse", dw::IcpConvergence::RelativeMse)
      .value("NoCorrespondences", dw::IcpConvergence::NoCorrespondences);
  using R = dw::FrameResult;
  py::class_<R>(m, "FrameResult", "One registered frame (dw::FrameResult).")
      .def_property_readonly(
          "pose", [](const R& r) { return r.pose; },
          "Sensor -> map, 4x4 float64; on a frame that is not ok, the prediction the track coasts on.")
      .def_readonly("status", &R::status)
      .def_property_readonly(
          "ok", [](const R& r) { return r.status == dw::FrameStatus::Ok; }, "status == FrameStatus.Ok")
      .def_property_readonly(
          "message", [](const R& r) { return std::string(dw::toString(r.status)); }, "The status in words.")
      .def_readonly("convergence", &R::convergence)
      .def_readonly("iterations", &R::iterations)
      .def_readonly("fitness", &R::fitness,
                    "Share of the registered scan points with a map point within max_distance.")
      .def_readonly("rmse", &R::rmse, "Of those correspondences, in the map's units.")
      .def_readonly("points", &R::points, "Scan points registered (finite, after downsampling).")
      .def_readonly("latency_seconds", &R::latency_seconds, "Wall time of the call, downsampling included.")
      .def_readonly("search_seconds", &R::search_seconds, "Of which in the correspondence search.")
      .def("__repr__", [](const R& r) {
        return "FrameResult(status=" + std::string(dw::toString(r.status)) +
               ", iterations=" + std::to_string(r.iterations) + ", fitness=" + std::to_string(r.fitness) +
               ", rmse=" + std::to_string(r.rmse) + ")";
      });
}

py::array_t<float> normalsArray(PyLocalizer& self) {
  std::vector<float> n = self.locked([](dw::Localizer& l) { return l.mapNormals(); });
  const auto rows = static_cast<py::ssize_t>(n.size() / 3);
  return adopt(std::move(n), {rows, py::ssize_t(3)});
}

void bindLocalizer(py::module_& m) {
  py::class_<PyLocalizer> c(m, "Localizer", R"doc(
Localization against a prior map (dw::Localizer): the map's Delaunay graph is built once (or taken
from a DelaunayGraph, copied, or loaded from a graph file path), and every scan is registered onto it
by the library's ICP loop from a constant-velocity prediction, warm-started where the previous frame's
walks ended. With the defaults a frame equals pcl::IterativeClosestPoint<PointXYZ, PointXYZ, double>
from the same guess (docs/localization.md).)doc");
  c.def(py::init([](py::handle map, const std::string& method, double max_distance, int max_iterations,
                    double transformation_epsilon, double fitness_epsilon, const std::string& kernel,
                    double kernel_scale, double voxel, bool constant_velocity, double min_fitness,
                    double max_rmse, std::size_t normal_k, bool warm_start, unsigned threads) {
          const IcpArgs icp{method,          max_distance, max_iterations, transformation_epsilon,
                            fitness_epsilon, kernel,       kernel_scale};
          return std::make_unique<PyLocalizer>(map, icp, voxel, constant_velocity, min_fitness, max_rmse,
                                               normal_k, warm_start, threads);
        }),
        py::arg("map"), py::kw_only(), py::arg("method") = "point_to_point", py::arg("max_distance") = 1.0,
        py::arg("max_iterations") = 30, py::arg("transformation_epsilon") = 1e-8,
        py::arg("fitness_epsilon") = -kInf, py::arg("kernel") = "none", py::arg("kernel_scale") = 1.0,
        py::arg("voxel") = 0.0, py::arg("constant_velocity") = true, py::arg("min_fitness") = 0.3,
        py::arg("max_rmse") = kInf, py::arg("normal_k") = 10, py::arg("warm_start") = true,
        py::arg("threads") = 0u, R"doc(
map: (n, 3) float32/float64 points (NaN/Inf skipped; the graph is built from their float32 values on
`threads` threads), a DelaunayGraph, or the path of a graph file (Localizer.save, DelaunayGraph.save).
method 'point_to_point' or 'point_to_plane' (map normals by PCA over the normal_k nearest map points);
kernel 'none', 'huber' or 'cauchy' with scale kernel_scale; max_distance: correspondence distance;
voxel: scan downsampling leaf (0: none); a frame whose fitness is below min_fitness or whose rmse is
above max_rmse is LostTrack; warm_start: start scan point i's walk where point i ended last frame.)doc");
  c.def("register_scan", &PyLocalizer::registerScan, py::arg("scan"), py::arg("init") = py::none(), R"doc(
Register one scan ((n, 3), sensor coordinates) and return its FrameResult. init: a 4x4 pose to start
from instead of the prediction (set_pose(init) first, which forgets the motion). Bad scan content
(empty, all NaN, outside the map) gives a status, never an exception.)doc");
  c.def("set_pose", &PyLocalizer::setPose, py::arg("pose"),
        "Set the pose (4x4, sensor -> map) and forget the motion: the next frame starts from it.");
  c.def_property_readonly(
      "pose", [](PyLocalizer& s) { return s.locked([](dw::Localizer& l) { return l.pose(); }); },
      "The current pose (4x4 float64, sensor -> map).");
  c.def_property_readonly(
      "predicted_pose",
      [](PyLocalizer& s) { return s.locked([](dw::Localizer& l) { return l.predictedPose(); }); },
      "The guess the next register_scan starts from (constant velocity).");
  c.def_property_readonly(
      "map_size", [](PyLocalizer& s) { return s.locked([](dw::Localizer& l) { return l.mapPoints(); }); },
      "Map points (the graph's input points).");
  c.def_property_readonly(
      "map_vertices",
      [](PyLocalizer& s) { return s.locked([](dw::Localizer& l) { return l.graph().numVertices(); }); },
      "Distinct finite map points (the graph's vertices).");
  c.def("map_normals", &normalsArray, "The map normals, (n, 3) float32 (computed on first use).");
  c.def(
      "save",
      [](PyLocalizer& s, const std::string& path) { s.locked([&](dw::Localizer& l) { l.save(path); }); },
      py::arg("path"), "Write the map graph (through a temporary file renamed over path).");
}

void bindOdometry(py::module_& m) {
  py::class_<PyOdometry> c(m, "SlidingWindowOdometry", R"doc(
LiDAR odometry on a sliding-window local map (dw::SlidingWindowOdometry): each scan is downsampled
(voxel), registered point-to-point onto the map from a constant-velocity prediction, and its points go
into the map (one per map voxel); points beyond max_range of the sensor or older than max_age frames go
out. Poses are in the first scan's frame (or the one given by set_pose).)doc");
  c.def(py::init([](double voxel, double max_range, unsigned max_age, double max_distance, int max_iterations,
                    double transformation_epsilon, double fitness_epsilon, const std::string& kernel,
                    double kernel_scale, double min_fitness, unsigned threads) {
          const IcpArgs icp{"point_to_point", max_distance, max_iterations, transformation_epsilon,
                            fitness_epsilon,  kernel,       kernel_scale};
          return std::make_unique<PyOdometry>(icp, voxel, max_range, max_age, min_fitness, threads);
        }),
        py::kw_only(), py::arg("voxel") = 0.5, py::arg("max_range") = 100.0, py::arg("max_age") = 0u,
        py::arg("max_distance") = 1.0, py::arg("max_iterations") = 30,
        py::arg("transformation_epsilon") = 1e-8, py::arg("fitness_epsilon") = -kInf,
        py::arg("kernel") = "none", py::arg("kernel_scale") = 1.0, py::arg("min_fitness") = 0.3,
        py::arg("threads") = 1u, R"doc(
voxel: scan downsampling leaf and map voxel (> 0); max_range: map points farther from the sensor are
removed; max_age: frames a map point lives (0: no limit); max_distance, max_iterations,
transformation_epsilon, fitness_epsilon, kernel, kernel_scale: the ICP loop's (as Localizer);
min_fitness: LostTrack below it; threads: correspondence search threads (0: all cores).)doc");
  const auto registerWithoutInit = [](PyOdometry& s, py::handle scan) {
    return s.registerScan(scan, py::none());
  };
  c.def("register_scan", registerWithoutInit, py::arg("scan"), R"doc(
Register one scan ((n, 3), sensor coordinates) onto the local map, update the map, and return the
FrameResult. The first scan makes the map. A frame that is not ok leaves the map alone.)doc");
  c.def("add_scan", registerWithoutInit, py::arg("scan"), "The same as register_scan.");
  c.def("set_pose", &PyOdometry::setPose, py::arg("pose"),
        "Set the pose (4x4, sensor -> map) and forget the motion.");
  c.def_property_readonly(
      "pose", [](PyOdometry& s) { return s.locked([](dw::SlidingWindowOdometry& o) { return o.pose(); }); },
      "The current pose (4x4 float64, sensor -> map frame).");
  c.def_property_readonly(
      "map_size",
      [](PyOdometry& s) { return s.locked([](dw::SlidingWindowOdometry& o) { return o.mapSize(); }); },
      "Points in the local map.");
  c.def_property_readonly(
      "frames",
      [](PyOdometry& s) { return s.locked([](dw::SlidingWindowOdometry& o) { return o.frames(); }); },
      "Scans registered so far.");
  c.def_property_readonly(
      "map_stats",
      [](PyOdometry& s) {
        const dw::OdometryMapStats st = s.locked([](dw::SlidingWindowOdometry& o) { return o.mapStats(); });
        py::dict d;
        d["inserted"] = st.inserted;
        d["removed"] = st.removed;
        d["insert_seconds"] = st.insert_seconds;
        d["remove_seconds"] = st.remove_seconds;
        d["graph_seconds"] = st.graph_seconds;
        return d;
      },
      "Map maintenance summed over frames: inserted, removed, insert_seconds, remove_seconds, "
      "graph_seconds.");
  c.def(
      "map_points",
      [](PyOdometry& s) {
        std::vector<double> xyz = s.locked([](dw::SlidingWindowOdometry& o) {
          const std::vector<dw::DynamicDelaunayGraph::PointId> ids = o.map().liveIds();
          std::vector<double> v;
          v.reserve(3 * ids.size());
          for (const auto id : ids) {
            const std::array<double, 3> p = o.map().position(id);
            v.insert(v.end(), p.begin(), p.end());
          }
          return v;
        });
        const auto rows = static_cast<py::ssize_t>(xyz.size() / 3);
        return adopt(std::move(xyz), {rows, py::ssize_t(3)});
      },
      "The local map's points, (n, 3) float64, in the map frame.");
}

}  // namespace

void bindLocalization(py::module_& m) {
  bindFrameResult(m);
  bindLocalizer(m);
  bindOdometry(m);
}

}  // namespace dw_py
