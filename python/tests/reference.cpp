// The C++ side of the Python tests and benchmark: the same work done through the C++ API directly.
//   dw_py_reference icp SOURCE.f32 TARGET.f32 point_to_point|point_to_plane MAX_IT MAX_DIST NORMAL_K
//                   THREADS M00 M01 ... M33
//       ICP with pcl::IterativeClosestPointDelaunayWalk; prints the transform, fitness, iterations and
//       convergence as hexadecimal floats, so the test compares them bit for bit.
//   dw_py_reference nearest POINTS.f32 QUERIES.f32 THREADS REPEATS
//       builds the graph, then times REPEATS batches of nearest-neighbour queries (KD-ANN start) as a
//       C++ user writes them: dw::parallelFor over the queries; prints the fastest batch's wall and
//       process CPU seconds.
//   dw_py_reference localize MAP.f32 point_to_point|point_to_plane none|huber|cauchy MAX_DIST VOXEL THREADS
//                   SCAN.f32...
//       dw::Localizer on the map, then one registerScan per scan (constant velocity); prints one line per
//       frame: status, iterations, fitness and the 16 pose entries (row by row) as hexadecimal floats.
//   dw_py_reference odometry VOXEL MAX_RANGE MAX_DIST THREADS SCAN.f32...
//       dw::SlidingWindowOdometry over the scans, printed as for localize, then the final map size.
// A .f32 file is raw little-endian float32 xyz triples.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/registration/localizer.h"
#include "pcl_delaunay_walk/core/registration/sliding_window_odometry.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "reference_nearest.h"  // python/src

#ifdef DW_PY_WITH_PCL
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#include <pcl/features/normal_3d.h>
#include <pcl/point_types.h>
#include <pcl/registration/transformation_estimation_point_to_plane_lls.h>

#include "pcl_delaunay_walk/registration/icp_delaunay_walk.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"
#endif

namespace {

std::vector<float> readF32(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.eof() && !in.good()) throw dw::Error("cannot read " + path);
  std::vector<float> v(bytes.size() / sizeof(float));
  std::copy(bytes.begin(), bytes.begin() + v.size() * sizeof(float), reinterpret_cast<char*>(v.data()));
  return v;
}

int nearestBench(char** argv) {
  const std::vector<float> pts = readF32(argv[0]), qs = readF32(argv[1]);
  const unsigned threads = static_cast<unsigned>(std::atoi(argv[2]));
  dw::BuildOptions options;
  options.num_threads = threads;
  auto graph = std::make_shared<dw::DelaunayGraph>(
      dw::buildDelaunayGraph(dw::PointView::fromFloat(pts.data(), pts.size() / 3), options));
  const dw::NeighbourSearch search(graph);
  const dw_py::ReferenceTiming t =
      dw_py::timeNearestBatch(search, qs.data(), qs.size() / 3, threads, std::atoi(argv[3]));
  std::printf("seconds %.9g\ncpu_seconds %.9g\nindex_sum %llu\n", t.seconds, t.cpu_seconds, t.index_sum);
  return 0;
}

void printFrame(const dw::FrameResult& r) {
  std::printf("frame %d %d %a", int(r.status), r.iterations, r.fitness);
  for (int k = 0; k < 16; ++k) std::printf(" %a", r.pose(k / 4, k % 4));
  std::printf("\n");
}

int localizeRun(int argc, char** argv) {
  const std::vector<float> map = readF32(argv[0]);
  const std::string method = argv[1], kernel = argv[2];
  dw::LocalizerOptions o;
  o.icp.metric = method == "point_to_plane" ? dw::IcpMetric::PointToPlane : dw::IcpMetric::PointToPoint;
  o.icp.kernel = kernel == "huber"    ? dw::RobustKernel::Huber
                 : kernel == "cauchy" ? dw::RobustKernel::Cauchy
                                      : dw::RobustKernel::None;
  o.icp.max_correspondence_distance = std::strtod(argv[3], nullptr);
  o.voxel = std::strtod(argv[4], nullptr);
  o.num_threads = static_cast<unsigned>(std::atoi(argv[5]));
  dw::Localizer loc(dw::PointView::fromFloat(map.data(), map.size() / 3), o);
  for (int i = 6; i < argc; ++i) {
    const std::vector<float> scan = readF32(argv[i]);
    printFrame(loc.registerScan(dw::PointView::fromFloat(scan.data(), scan.size() / 3)));
  }
  return 0;
}

int odometryRun(int argc, char** argv) {
  dw::OdometryOptions o;
  o.voxel = std::strtod(argv[0], nullptr);
  o.max_range = std::strtod(argv[1], nullptr);
  o.icp.max_correspondence_distance = std::strtod(argv[2], nullptr);
  o.num_threads = static_cast<unsigned>(std::atoi(argv[3]));
  dw::SlidingWindowOdometry odo(o);
  for (int i = 4; i < argc; ++i) {
    const std::vector<float> scan = readF32(argv[i]);
    printFrame(odo.registerScan(dw::PointView::fromFloat(scan.data(), scan.size() / 3)));
  }
  std::printf("map %zu\n", odo.mapSize());
  return 0;
}

#ifdef DW_PY_WITH_PCL
template <typename P>
int icpRun(char** argv, bool point_to_plane) {
  auto cloud = [](const std::string& path) {
    const std::vector<float> v = readF32(path);
    typename pcl::PointCloud<P>::Ptr c(new pcl::PointCloud<P>);
    c->resize(v.size() / 3);
    for (std::size_t i = 0; i < c->size(); ++i)
      (*c)[i].x = v[3 * i], (*c)[i].y = v[3 * i + 1], (*c)[i].z = v[3 * i + 2];
    return c;
  };
  auto source = cloud(argv[0]), target = cloud(argv[1]);
  pcl::IterativeClosestPointDelaunayWalk<P, P> icp;
  if constexpr (std::is_same<P, pcl::PointNormal>::value) {
    pcl::NormalEstimation<P, pcl::Normal> ne;
    ne.setSearchMethod(std::make_shared<pcl::search::DelaunayWalk<P>>());
    ne.setInputCloud(target);
    ne.setKSearch(std::atoi(argv[5]));
    pcl::PointCloud<pcl::Normal> normals;
    ne.compute(normals);
    for (std::size_t i = 0; i < target->size(); ++i)
      for (int a = 0; a < 3; ++a) (*target)[i].normal[a] = normals[i].normal[a];
    icp.setTransformationEstimation(
        std::make_shared<pcl::registration::TransformationEstimationPointToPlaneLLS<P, P>>());
  }
  (void)point_to_plane;
  icp.setInputSource(source);
  icp.setInputTarget(target);
  icp.setMaximumIterations(std::atoi(argv[3]));
  const double max_distance = std::strtod(argv[4], nullptr);
  icp.setMaxCorrespondenceDistance(max_distance);
  icp.setNumberOfThreads(static_cast<unsigned>(std::atoi(argv[6])));
  Eigen::Matrix4f init;
  for (int k = 0; k < 16; ++k) init(k / 4, k % 4) = static_cast<float>(std::strtod(argv[7 + k], nullptr));
  pcl::PointCloud<P> aligned;
  icp.align(aligned, init);
  const Eigen::Matrix4f t = icp.getFinalTransformation();
  std::printf("transform");
  for (int k = 0; k < 16; ++k) std::printf(" %a", double(t(k / 4, k % 4)));
  std::printf("\nfitness %a\niterations %zu\nconverged %d\n",
              icp.getFitnessScore(max_distance * max_distance), icp.getIterationStatistics().size(),
              int(icp.hasConverged()));
  return 0;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string what = argc > 1 ? argv[1] : "";
    if (what == "nearest" && argc == 6) return nearestBench(argv + 2);
    if (what == "localize" && argc >= 8) return localizeRun(argc - 2, argv + 2);
    if (what == "odometry" && argc >= 6) return odometryRun(argc - 2, argv + 2);
#ifdef DW_PY_WITH_PCL
    if (what == "icp" && argc == 25)
      return std::string(argv[4]) == "point_to_plane" ? icpRun<pcl::PointNormal>(argv + 2, true)
                                                      : icpRun<pcl::PointXYZ>(argv + 2, false);
#endif
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_py_reference: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr, "usage: see the comment at the top of python/tests/reference.cpp\n");
  return 2;
}
