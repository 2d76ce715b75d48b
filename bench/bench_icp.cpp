// Google Benchmark: one align() of stock pcl::IterativeClosestPoint (seed §5 protocol: rotation
// 10/10/10 degrees, at most 100 iterations, error 1e-11), with each NN method plugged in.
//
//   ICP/<data set>/stock-kdtree               out of the box: align() builds FLANN itself
//   ICP/<data set>/walk-estimator             CorrespondenceEstimationDelaunayWalk, graph prebuilt
//   ICP/<data set>/walk-estimator+build       the same, graph built inside the timed region
//   ICP/<data set>/<method>                   any NnMethod through MethodCorrespondenceEstimation,
//                                             structure prebuilt (nanoflann, octree, core walks)
//
// Data sets: $DW_BENCH_DATASETS (comma list, default dragon-23k,dragon-100k).
// GCC 12 reports -Warray-bounds false positives inside Eigen's SSE loads of Vector3f when it inlines
// PCL's SVD transformation estimation (the 16-byte load of a 12-byte vector is masked). GCC judges
// the diagnostic by the state at the system header's location, so this must precede every include.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <iostream>
#include <map>
#include <sstream>

#include "common/icp_estimators.h"
#include "common/rotation_protocol.h"
#include "pcl_delaunay_walk/registration/correspondence_estimation_delaunay_walk.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"
#include "pcl_delaunay_walk/search/kdtree_delaunay_walk.h"

namespace {

using dwb::Cloud;
using dwb::PointT;
using WalkCE = pcl::registration::CorrespondenceEstimationDelaunayWalk<PointT, PointT, float>;

struct Problem {
  Cloud::Ptr source, target;
  std::vector<float> target_xyz;
};

std::map<std::string, Problem>& problems() {
  static std::map<std::string, Problem> p;
  return p;
}

void reportIterations(benchmark::State& state, std::size_t iterations) {
  state.counters["icp_iterations"] = double(iterations);
  // Seconds per ICP iteration (printed with an SI prefix, e.g. 7.4m = 7.4 ms), from CPU time.
  state.counters["s_per_icp_iteration"] = benchmark::Counter(
      double(iterations), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void benchStock(benchmark::State& state, std::string data) {
  const Problem& p = problems().at(data);
  Cloud out;
  dwb::IterationClock clock;
  for (auto _ : state) {
    pcl::IterativeClosestPoint<PointT, PointT, float> icp;
    dwb::configureIcp(icp, 100);
    icp.setCorrespondenceEstimation(std::make_shared<dwb::TimedStockCorrespondenceEstimation>(&clock));
    icp.setInputSource(p.source);
    icp.setInputTarget(p.target);
    clock.begin();
    icp.align(out);
  }
  reportIterations(state, clock.iterations());
}

void benchWalkEstimator(benchmark::State& state, std::string data, bool with_build) {
  const Problem& p = problems().at(data);
  Cloud out;
  auto walk = std::make_shared<pcl::search::DelaunayWalk<PointT>>();
  if (!with_build) walk->setInputCloud(p.target);
  std::size_t iterations = 0;
  for (auto _ : state) {
    if (with_build) {
      walk = std::make_shared<pcl::search::DelaunayWalk<PointT>>();
      walk->setInputCloud(p.target);
    }
    pcl::IterativeClosestPoint<PointT, PointT, float> icp;
    dwb::configureIcp(icp, 100);
    auto ce = std::make_shared<WalkCE>(walk);
    ce->setNumberOfThreads(1);
    icp.setCorrespondenceEstimation(ce);
    icp.setSearchMethodTarget(std::make_shared<pcl::search::KdTreeDelaunayWalk<PointT>>(walk));
    icp.setInputSource(p.source);
    icp.setInputTarget(p.target);
    icp.align(out);
    iterations = ce->getStatistics().size();
  }
  reportIterations(state, iterations);
  state.counters["graph_builds"] = double(walk->getNumberOfBuilds());
}

void benchMethod(benchmark::State& state, std::string data, std::string method) {
  const Problem& p = problems().at(data);
  std::shared_ptr<dwb::NnMethod> m = dwb::makeMethod(method);
  m->build(p.target_xyz);
  dwb::IterationClock clock;
  Cloud out;
  for (auto _ : state) {
    pcl::IterativeClosestPoint<PointT, PointT, float> icp;
    dwb::configureIcp(icp, 100);
    icp.setCorrespondenceEstimation(std::make_shared<dwb::MethodCorrespondenceEstimation>(m, &clock, 1));
    icp.setSearchMethodTarget(pcl::search::KdTree<PointT>::Ptr(new pcl::search::KdTree<PointT>), true);
    icp.setInputSource(p.source);
    icp.setInputTarget(p.target);
    clock.begin();
    icp.align(out);
  }
  reportIterations(state, clock.iterations());
}

}  // namespace

int main(int argc, char** argv) {
  const char* env = std::getenv("DW_BENCH_DATASETS");
  std::stringstream list(env ? env : "dragon-23k,dragon-100k");
  std::string d;
  while (std::getline(list, d, ',')) {
    if (d.empty()) continue;
    try {
      dwb::Dataset data = dwb::loadDataset(d);
      Problem p;
      p.target_xyz = data.xyz;
      p.target = dwb::toCloud(data.xyz);
      p.source =
          dwb::toCloud(dwb::transformed(data.xyz, dwb::Rotation{10, 10, 10}.about(dwb::centroid(data.xyz))));
      problems()[d] = p;
    } catch (const std::exception& e) {
      std::cerr << "bench_icp: skipping " << d << ": " << e.what() << "\n";
      continue;
    }
    benchmark::RegisterBenchmark(("ICP/" + d + "/stock-kdtree").c_str(), benchStock, d)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("ICP/" + d + "/walk-estimator").c_str(), benchWalkEstimator, d, false)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("ICP/" + d + "/walk-estimator+build").c_str(), benchWalkEstimator, d, true)
        ->Unit(benchmark::kMillisecond);
    for (const char* m : {"nanoflann", "pcl-octree", "walk-kd-ann", "walk-pnn", "walk-pnn-optimized"})
      if (dwb::makeMethod(m))
        benchmark::RegisterBenchmark(("ICP/" + d + "/" + m).c_str(), benchMethod, d, std::string(m))
            ->Unit(benchmark::kMillisecond);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
