// icp(): pcl::IterativeClosestPointDelaunayWalk from NumPy, point-to-point (SVD) or point-to-plane
// (TransformationEstimationPointToPlaneLLS on target normals from pcl::NormalEstimation, whose kNN is a
// pcl::search::DelaunayWalk). The clouds are copied into PCL's padded point layout; align() runs with
// the GIL released.
// PCL's SVD estimation, instantiated through icp.h, trips GCC 12 false positives inside Eigen.
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#include <pcl/features/normal_3d.h>
#include <pcl/point_types.h>
#include <pcl/registration/transformation_estimation_point_to_plane_lls.h>
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "arrays.h"
#include "bindings.h"
#include "pcl_delaunay_walk/registration/icp_delaunay_walk.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"

namespace dw_py {

namespace {

struct IcpSettings {
  bool point_to_plane = false;
  int max_iterations = 50;
  double max_distance = std::sqrt(std::numeric_limits<double>::max());  // PCL's default: no limit
  double transformation_epsilon = 0.0;
  double fitness_epsilon = -std::numeric_limits<double>::max();
  int normal_k = 15;
  dw::StartStrategy strategy = dw::StartStrategy::PnnOptimized;
  unsigned threads = 0;
  std::shared_ptr<dw::DelaunayGraph> graph;
};

/// The iteration count is a protected member of pcl::Registration; this is the one way to read it.
template <typename P>
class Icp : public pcl::IterativeClosestPointDelaunayWalk<P, P, float> {
 public:
  int iterations() const { return this->nr_iterations_; }
};

template <typename P>
typename pcl::PointCloud<P>::Ptr toCloud(const Points& p) {
  typename pcl::PointCloud<P>::Ptr c(new pcl::PointCloud<P>);
  c->resize(p.n);
  bool dense = true;
  for (std::size_t i = 0; i < p.n; ++i) {
    P& q = (*c)[i];
    for (int k = 0; k < 3; ++k) {
      q.data[k] = static_cast<float>(p.is_double ? p.at<double>(i, k) : p.at<float>(i, k));
      dense = dense && std::isfinite(q.data[k]);
    }
  }
  c->is_dense = dense;
  return c;
}

/// Target normals by PCA over the normal_k nearest target points, the kNN answered by the walk.
void estimateNormals(pcl::PointCloud<pcl::PointNormal>::Ptr& target, int k) {
  pcl::NormalEstimation<pcl::PointNormal, pcl::Normal> ne;
  ne.setSearchMethod(std::make_shared<pcl::search::DelaunayWalk<pcl::PointNormal>>());
  ne.setInputCloud(target);
  ne.setKSearch(k);
  pcl::PointCloud<pcl::Normal> normals;
  ne.compute(normals);
  for (std::size_t i = 0; i < target->size(); ++i)
    for (int a = 0; a < 3; ++a) (*target)[i].normal[a] = normals[i].normal[a];
}

template <typename P>
py::dict run(const Points& source, const Points& target, const Eigen::Matrix4f& init, const IcpSettings& s) {
  auto src = toCloud<P>(source), tgt = toCloud<P>(target);
  Icp<P> icp;
  pcl::PointCloud<P> aligned;
  {
    py::gil_scoped_release release;
    if constexpr (std::is_same<P, pcl::PointNormal>::value) {
      estimateNormals(tgt, s.normal_k);
      icp.setTransformationEstimation(
          std::make_shared<pcl::registration::TransformationEstimationPointToPlaneLLS<P, P, float>>());
    }
    icp.setInputSource(src);
    icp.setInputTarget(tgt);
    if (s.graph) icp.setTargetGraph(s.graph);
    icp.setMaximumIterations(s.max_iterations);
    icp.setMaxCorrespondenceDistance(s.max_distance);
    icp.setTransformationEpsilon(s.transformation_epsilon);
    icp.setEuclideanFitnessEpsilon(s.fitness_epsilon);
    icp.setStartStrategy(s.strategy);
    icp.setNumberOfThreads(s.threads);
    icp.align(aligned, init);
  }
  py::list stats;
  for (const auto& st : icp.getIterationStatistics()) {
    py::dict d;
    d["queries"] = st.queries;
    d["correspondences"] = st.correspondences;
    d["walk_steps"] = st.walk_steps;
    d["widened"] = st.widened;
    d["nn_seconds"] = st.nn_seconds;
    stats.append(d);
  }
  py::dict r;
  r["transform"] = Eigen::Matrix4d(icp.getFinalTransformation().template cast<double>());
  r["fitness"] = icp.getFitnessScore(s.max_distance * s.max_distance);
  r["converged"] = icp.hasConverged();
  r["iterations"] = icp.iterations();
  r["graph_seconds"] = icp.getGraphBuildSeconds();
  r["statistics"] = stats;
  return r;
}

py::dict icp(py::handle source, py::handle target, const std::string& method, py::object init,
             int max_iterations, double max_distance, double transformation_epsilon, double fitness_epsilon,
             int normal_k, const std::string& strategy, unsigned threads,
             std::shared_ptr<dw::DelaunayGraph> graph) {
  const Points src = pointsArg(source, "source"), tgt = pointsArg(target, "target");
  IcpSettings s;
  if (method == "point_to_plane")
    s.point_to_plane = true;
  else if (method != "point_to_point")
    throw py::value_error("method must be 'point_to_point' or 'point_to_plane', got '" + method + "'");
  if (max_iterations < 1) throw py::value_error("max_iterations must be at least 1");
  if (normal_k < 3) throw py::value_error("normal_k must be at least 3");
  s.max_iterations = max_iterations;
  if (!std::isinf(max_distance)) s.max_distance = max_distance;
  s.transformation_epsilon = transformation_epsilon;
  if (!std::isinf(fitness_epsilon)) s.fitness_epsilon = fitness_epsilon;
  s.normal_k = normal_k;
  s.strategy = dw::parseStartStrategy(strategy);
  s.threads = threads;
  s.graph = std::move(graph);
  Eigen::Matrix4f guess = Eigen::Matrix4f::Identity();
  if (!init.is_none()) {
    const py::array a = py::array::ensure(init);
    if (!a || a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
      throw py::value_error("init must be a 4x4 matrix");
    guess = init.cast<Eigen::Matrix4d>().cast<float>();
  }
  return s.point_to_plane ? run<pcl::PointNormal>(src, tgt, guess, s)
                          : run<pcl::PointXYZ>(src, tgt, guess, s);
}

}  // namespace

void bindIcp(py::module_& m) {
  const double inf = std::numeric_limits<double>::infinity();
  m.def("icp", &icp, py::arg("source"), py::arg("target"), py::arg("method") = "point_to_point",
        py::arg("init") = py::none(), py::arg("max_iterations") = 50, py::arg("max_distance") = inf,
        py::arg("transformation_epsilon") = 0.0, py::arg("fitness_epsilon") = -inf, py::arg("normal_k") = 15,
        py::arg("strategy") = "pnn-optimized", py::arg("threads") = 0u, py::arg("graph") = nullptr, R"doc(
Register source onto target with pcl::IterativeClosestPointDelaunayWalk (float, as PCL's ICP).

method 'point_to_point' (SVD) or 'point_to_plane' (linear least squares on target normals estimated
from the normal_k nearest target points). `graph`: a prebuilt DelaunayGraph of exactly `target` (checked;
reused instead of building one). Returns {'transform': 4x4 float64, 'fitness', 'converged',
'iterations', 'graph_seconds', 'statistics': one dict per iteration (queries, correspondences,
walk_steps, widened, nn_seconds)}; fitness is PCL's getFitnessScore over pairs within max_distance.)doc");
}

}  // namespace dw_py
