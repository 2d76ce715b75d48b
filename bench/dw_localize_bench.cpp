// dw_localize_bench: per-frame time of localization against a prior map, one process, side by side:
//   - walk:      the localizer's ICP loop (core/registration/icp.h) over the Delaunay walk, warm starts
//                within and across frames;
//   - nanoflann: the same loop over nanoflann 1.12.1's static KDTreeSingleIndexAdaptor (leaf 10);
//   - pcl:       stock pcl::IterativeClosestPoint<PointXYZ, PointXYZ, double> with a prebuilt
//                pcl::search::KdTree (only in a build with PCL).
// Same scans, same guesses (each method's own constant-velocity prediction), same distance,
// iterations and epsilons; ratios are the peer's time over the walk's. The exact peers' poses must
// equal the walk's within 1e-6 relative (printed). With --odometry it also measures the sliding-window
// map's insert and remove rates (dw::DynamicDelaunayGraph) beside nanoflann 1.12.1's
// KDTreeSingleIndexIncrementalAdaptor on the same stream, then the odometry twice: deleting retired
// points from the triangulation every frame, and retiring them until a compaction (the default).
//
//   dw_localize_bench [--map-points 2M] [--scan-points 120k] [--frames 10] [--threads 0] [--kitti DIR]
//                     [--max-distance 1] [--odometry] [--no-pcl] [--seed 1] [--graph-file TMP.graph]
//                     [--scan-order sensor|random] [--no-maintenance]
// The street's scans come in sensor order (azimuth columns, as a spinning LiDAR delivers them) unless
// --scan-order random shuffles them, the warm starts' worst case. --no-maintenance leaves out the
// insert/remove rate tables (the odometry rows only).
// --graph-file also times saving the walk's map graph there and loading it back, by mmap (as
// dw::Localizer::load does) and by copy (the file is removed).
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "app_args.h"
#include "pcl_delaunay_walk/core/graph/dynamic_delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/core/registration/icp.h"
#include "pcl_delaunay_walk/core/registration/sliding_window_odometry.h"
#include "pcl_delaunay_walk/core/registration/voxel_downsample.h"
#include "pcl_delaunay_walk/core/registration/walk_correspondence_search.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#include "synthetic_street.h"

#ifdef DW_HAVE_NANOFLANN_PEER
#include <nanoflann.hpp>
#endif
#ifdef DW_BENCH_PCL
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#include <pcl/registration/icp.h>
#include <pcl/search/kdtree.h>
#endif

namespace {

// Thread CPU time beside wall time: the development machine is shared by several builds, where wall
// time of a one-thread step mostly measures the waits for a core.
double cpuNow() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

struct Options {
  std::size_t map_points = 2000000, scan_points = 120000, frames = 10;
  unsigned threads = 0;
  std::string kitti, graph_file;
  double max_distance = 1.0;
  bool odometry = false, maintenance = true, pcl = true;
  dw_bench::ScanOrder scan_order = dw_bench::ScanOrder::kSensor;
  unsigned seed = 1;
};

struct Scene {
  std::string name;
  std::vector<float> map;
  std::vector<std::vector<float>> scans;
  std::vector<Eigen::Matrix4d> truth;  ///< sensor -> map per scan
};

Scene makeSynthetic(const Options& o) {
  Scene s;
  s.name = "synthetic " + std::to_string(o.map_points) + "-point street, scans in " +
           (o.scan_order == dw_bench::ScanOrder::kSensor ? "sensor" : "random") + " order";
  const auto t0 = Clock::now();
  s.map = dw_bench::syntheticStreet(o.map_points, o.seed);
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  pose(0, 3) = -60, pose(2, 3) = 1.8;
  Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
  step.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  step(0, 3) = 1.0;  // 10 m/s at 10 Hz
  for (std::size_t k = 0; k < o.frames; ++k) {
    s.truth.push_back(pose);
    s.scans.push_back(
        dw_bench::cutStreetScan(s.map, pose, 60.0, o.scan_points, o.seed + unsigned(k), o.scan_order));
    pose = pose * step;
  }
  std::printf("scene: %s, %zu scans of ~%zu points, made in %.2f s\n", s.name.c_str(), s.scans.size(),
              s.scans.empty() ? 0 : s.scans[0].size() / 3, since(t0));
  return s;
}

/// The KITTI pair: frame 000000 as the map, frame 000001 as every scan (truth unknown: identity guess).
bool makeKitti(const Options& o, Scene& s) {
  const std::string a = o.kitti + "/kitti_000000.bin", b = o.kitti + "/kitti_000001.bin";
  if (!std::ifstream(a).good() || !std::ifstream(b).good()) {
    std::printf("KITTI frames absent under '%s': skipped\n", o.kitti.c_str());
    return false;
  }
  const std::vector<double> m = dw::readPointsXyz(a), q = dw::readPointsXyz(b);
  s.name = "KITTI 000001 onto 000000 (" + std::to_string(m.size() / 3) + "-point map)";
  s.map.assign(m.begin(), m.end());
  for (std::size_t k = 0; k < std::max<std::size_t>(1, o.frames / 2); ++k) {
    s.scans.emplace_back(q.begin(), q.end());
    s.truth.push_back(Eigen::Matrix4d::Identity());
  }
  return true;
}

dw::IcpOptions icpOptions(const Options& o) {
  dw::IcpOptions icp;
  icp.max_correspondence_distance = o.max_distance;
  icp.max_iterations = 30;
  icp.transformation_epsilon = 1e-8;
  icp.num_threads = o.threads;
  return icp;
}

struct RunResult {
  std::string method;
  double build_s = 0;
  std::vector<double> frame_ms;
  std::vector<Eigen::Matrix4d> poses;
  double iterations = 0;
};

/// The sequence through alignIcp: the first guess is the true pose (a KITTI pair: identity), then a
/// constant-velocity prediction from the method's own poses.
void runLoop(const dw::CorrespondenceSearch& search, const Scene& s, const Options& o, RunResult& r) {
  dw::IcpWorkspace ws;
  Eigen::Matrix4d prev = s.truth[0], vel = Eigen::Matrix4d::Identity();
  const bool sequence = s.truth.size() > 1 && s.truth[1] != s.truth[0];
  for (std::size_t k = 0; k < s.scans.size(); ++k) {
    const Eigen::Matrix4d guess = sequence ? Eigen::Matrix4d(k == 0 ? s.truth[0] : prev * vel) : s.truth[k];
    if (!sequence) ws.hints.clear();  // the same scan again: no warm start from the previous answer
    const auto t0 = Clock::now();
    const dw::IcpResult res =
        dw::alignIcp(search, nullptr, s.scans[k].data(), s.scans[k].size() / 3, guess, icpOptions(o), ws);
    r.frame_ms.push_back(1e3 * since(t0));
    r.iterations += res.iterations;
    r.poses.push_back(res.transform);
    if (k > 0) vel = prev.inverse() * res.transform;
    prev = res.transform;
  }
  r.iterations /= double(s.scans.size());
}

#ifdef DW_HAVE_NANOFLANN_PEER
struct FloatCloud {
  const std::vector<float>* xyz;
  std::size_t kdtree_get_point_count() const { return xyz->size() / 3; }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return (*xyz)[3 * i + d]; }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using NanoTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, FloatCloud>,
                                                     FloatCloud, 3, std::uint32_t>;

class NanoflannSearch final : public dw::CorrespondenceSearch {
 public:
  NanoflannSearch(const std::vector<float>& xyz, unsigned threads)
      : cloud_{&xyz},
        tree_(3, cloud_,
              nanoflann::KDTreeSingleIndexAdaptorParams(10, nanoflann::KDTreeSingleIndexAdaptorFlags::None,
                                                        dw::resolveThreads(threads))) {}
  std::size_t size() const override { return cloud_.kdtree_get_point_count(); }
  const float* point(std::size_t i) const override { return &(*cloud_.xyz)[3 * i]; }
  bool nearest(const float q[3], dw::index_t&, std::int32_t& index, float& dist2) const override {
    if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) return false;
    std::uint32_t i = 0;
    float d = 0;
    if (tree_.knnSearch(q, 1, &i, &d) != 1) return false;
    index = std::int32_t(i);
    dist2 = d;
    return true;
  }

 private:
  FloatCloud cloud_;
  NanoTree tree_;
};
#endif

#ifdef DW_BENCH_PCL
void runPcl(const Scene& s, const Options& o, const std::vector<Eigen::Matrix4d>& guesses, RunResult& r) {
  using P = pcl::PointXYZ;
  pcl::PointCloud<P>::Ptr map(new pcl::PointCloud<P>);
  for (std::size_t i = 0; i < s.map.size() / 3; ++i)
    map->push_back(P(s.map[3 * i], s.map[3 * i + 1], s.map[3 * i + 2]));
  const auto t0 = Clock::now();
  pcl::search::KdTree<P>::Ptr tree(new pcl::search::KdTree<P>);
  tree->setInputCloud(map);
  r.build_s = since(t0);
  for (std::size_t k = 0; k < s.scans.size(); ++k) {
    pcl::PointCloud<P>::Ptr scan(new pcl::PointCloud<P>);
    for (std::size_t i = 0; i < s.scans[k].size() / 3; ++i)
      scan->push_back(P(s.scans[k][3 * i], s.scans[k][3 * i + 1], s.scans[k][3 * i + 2]));
    struct Icp : pcl::IterativeClosestPoint<P, P, double> {
      using pcl::IterativeClosestPoint<P, P, double>::nr_iterations_;
    } icp;
    icp.setInputTarget(map);
    icp.setSearchMethodTarget(tree, true);  // the prebuilt tree: no rebuild per frame
    icp.setInputSource(scan);
    icp.setMaxCorrespondenceDistance(o.max_distance);
    icp.setMaximumIterations(30);
    icp.setTransformationEpsilon(1e-8);
    pcl::PointCloud<P> aligned;
    const auto t1 = Clock::now();
    icp.align(aligned, guesses[k]);
    r.frame_ms.push_back(1e3 * since(t1));
    r.iterations += icp.nr_iterations_;
    r.poses.push_back(icp.getFinalTransformation());
  }
  r.iterations /= double(s.scans.size());
}
#endif

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[std::min(v.size() - 1, std::size_t(std::ceil(q * double(v.size()))) - 1)];
}

double maxRelativeDifference(const std::vector<Eigen::Matrix4d>& a, const std::vector<Eigen::Matrix4d>& b) {
  double worst = 0;
  for (std::size_t k = 0; k < std::min(a.size(), b.size()); ++k)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j)
        worst = std::max(worst, std::fabs(a[k](i, j) - b[k](i, j)) / std::max(1.0, std::fabs(b[k](i, j))));
  return worst;
}

/// Saves the map graph to `path`, loads it back (dw::loadGraph: read, checksums, validation) and
/// removes the file: what a localizer that starts from a saved map pays.
void timeGraphFile(const dw::DelaunayGraph& g, const std::string& path) {
  auto t0 = Clock::now();
  dw::saveGraph(g, path);
  const double save_s = since(t0);
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  const double mb = double(f.tellg()) / 1e6;
  // Each load once, in this order, the page cache warm from the save: the mapped load (what
  // dw::Localizer::load and loadMap do), then the copying one for comparison.
  t0 = Clock::now();
  const dw::DelaunayGraph mapped = dw::loadGraph(path);
  const double map_s = since(t0);
  t0 = Clock::now();
  const dw::DelaunayGraph copied = dw::loadGraph(path, dw::GraphStorage::Copied);
  const double copy_s = since(t0);
  std::remove(path.c_str());
  if (!mapped.isMapped() || copied.numDirectedEdges() != mapped.numDirectedEdges())
    throw dw::Error("the mapped and the copied load disagree");
  std::printf(
      "map graph file: %.1f MB, %zu vertices, saved in %.3f s; loaded (checked) by mmap in %.3f s "
      "(%.0f MB/s), by copy in %.3f s (%.0f MB/s)\n",
      mb, mapped.numVertices(), save_s, map_s, mb / map_s, copy_s, mb / copy_s);
}

/// The map graph's neighbourhood sizes: a walk step reads one whole neighbourhood.
void printDegrees(const dw::DelaunayGraph& g) {
  std::vector<dw::index_t> degree(g.numVertices());
  for (std::size_t v = 0; v < degree.size(); ++v) degree[v] = g.offsets[v + 1] - g.offsets[v];
  std::sort(degree.begin(), degree.end());
  if (degree.empty()) return;
  auto at = [&](double q) {
    return degree[std::min(degree.size() - 1, std::size_t(q * double(degree.size())))];
  };
  std::printf("map graph: %zu vertices, mean degree %.1f, median %u, p99 %u, max %u\n", degree.size(),
              double(g.numDirectedEdges()) / double(degree.size()), at(0.5), at(0.99), degree.back());
}

void benchScene(const Scene& s, const Options& o) {
  std::vector<RunResult> runs;
  {
    RunResult r;
    r.method = "walk";
    const auto t0 = Clock::now();
    dw::BuildOptions b;
    b.num_threads = o.threads;
    auto g = std::make_shared<const dw::DelaunayGraph>(
        dw::buildDelaunayGraph(dw::PointView::fromFloat(s.map.data(), s.map.size() / 3), b));
    const dw::WalkCorrespondenceSearch search(
        std::make_shared<const dw::CallerMetricSearch>(g, s.map, std::vector<std::int32_t>{}),
        dw::StartStrategy::PnnOptimized, 4.0 * o.max_distance);  // as dw::Localizer sets it
    r.build_s = since(t0);
    printDegrees(*g);
    if (!o.graph_file.empty()) {
      try {  // a full disk costs this line, not the tables
        timeGraphFile(*g, o.graph_file);
      } catch (const std::exception& e) {
        std::remove(o.graph_file.c_str());
        std::printf("map graph file: not timed (%s)\n", e.what());
      }
    }
    runLoop(search, s, o, r);
    runs.push_back(std::move(r));
  }
#ifdef DW_HAVE_NANOFLANN_PEER
  {
    RunResult r;
    r.method = "nanoflann " NANOFLANN_VERSION_STRING;
    const auto t0 = Clock::now();
    const NanoflannSearch search(s.map, o.threads);
    r.build_s = since(t0);
    runLoop(search, s, o, r);
    runs.push_back(std::move(r));
  }
#else
  std::printf("nanoflann 1.12.1 (../shared/peers/nanoflann) not found at build time: skipped\n");
#endif
#ifdef DW_BENCH_PCL
  if (o.pcl) {
    // PCL starts each frame where the walk's run did, so the frames are the same registrations.
    std::vector<Eigen::Matrix4d> guesses;
    const bool sequence = s.truth.size() > 1 && s.truth[1] != s.truth[0];
    for (std::size_t k = 0; k < s.scans.size(); ++k) {
      if (!sequence || k == 0)
        guesses.push_back(s.truth[k]);
      else if (k == 1)
        guesses.push_back(runs[0].poses[0]);
      else
        guesses.push_back(runs[0].poses[k - 1] * (runs[0].poses[k - 2].inverse() * runs[0].poses[k - 1]));
    }
    RunResult r;
    r.method = "PCL ICP + KdTree";
    runPcl(s, o, guesses, r);
    runs.push_back(std::move(r));
  }
#endif
  std::printf("\n%s, %u threads, max distance %.2f m\n", s.name.c_str(), dw::resolveThreads(o.threads),
              o.max_distance);
  std::printf("%-22s %10s %10s %10s %10s %8s %10s %14s\n", "method", "build s", "p50 ms", "mean ms", "max ms",
              "iters", "ratio p50", "max rel diff");
  const double walk_p50 = percentile(runs[0].frame_ms, 0.5);
  for (const RunResult& r : runs) {
    double mean = 0;
    for (double m : r.frame_ms) mean += m;
    mean /= double(std::max<std::size_t>(1, r.frame_ms.size()));
    std::printf("%-22s %10.3f %10.2f %10.2f %10.2f %8.2f %9.2fx %14.2e\n", r.method.c_str(), r.build_s,
                percentile(r.frame_ms, 0.5), mean, *std::max_element(r.frame_ms.begin(), r.frame_ms.end()),
                r.iterations, percentile(r.frame_ms, 0.5) / walk_p50,
                maxRelativeDifference(r.poses, runs[0].poses));
  }
}

/// Map maintenance on the scene's scan stream at the true poses: each frame's points (downsampled to
/// `voxel`, or all with 0) go in where their map voxel is empty, points beyond `range` of the sensor go
/// out. The same insert and remove sets for dw::DynamicDelaunayGraph and nanoflann's incremental tree.
void benchMapMaintenance(const Scene& s, double voxel, double range) {
  struct Batch {
    std::vector<float> in;
    std::vector<std::size_t> out;  // indices into the stream of inserted points
  };
  std::vector<Batch> batches;
  std::vector<float> stream;  // every inserted point, in order
  {
    std::vector<std::uint64_t> keys;
    std::vector<bool> live;
    std::unordered_map<std::uint64_t, std::size_t> occupied;
    const double cell = voxel > 0 ? voxel : 0.02;
    for (std::size_t k = 0; k < s.scans.size(); ++k) {
      Batch b;
      const Eigen::Matrix4d& t = s.truth[k];
      const Eigen::Vector3d c = t.topRightCorner<3, 1>();
      for (std::size_t i = 0; i < live.size(); ++i) {
        if (!live[i]) continue;
        const Eigen::Vector3d p(stream[3 * i], stream[3 * i + 1], stream[3 * i + 2]);
        if ((p - c).norm() > range) b.out.push_back(i), live[i] = false, occupied.erase(keys[i]);
      }
      const std::vector<float> pts =
          dw::voxelDownsample(dw::PointView::fromFloat(s.scans[k].data(), s.scans[k].size() / 3), voxel);
      for (std::size_t i = 0; i < pts.size() / 3; ++i) {
        const Eigen::Vector4d q = t * Eigen::Vector4d(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2], 1);
        std::uint64_t key = 0;
        for (int d = 0; d < 3; ++d)
          key = (key << 21) | (std::uint64_t(std::int64_t(std::floor(q(d) / cell))) & ((1u << 21) - 1));
        if (!occupied.emplace(key, stream.size() / 3).second) continue;
        keys.push_back(key);
        live.push_back(true);
        b.in.insert(b.in.end(), {float(q(0)), float(q(1)), float(q(2))});
        stream.insert(stream.end(), {float(q(0)), float(q(1)), float(q(2))});
      }
      batches.push_back(std::move(b));
    }
  }
  std::size_t inserted = 0, removed = 0;
  double dw_in = 0, dw_out = 0, dw_in_cpu = 0, dw_out_cpu = 0;
  {
    dw::DynamicDelaunayGraph map(std::array<double, 3>{{0.0, 0.0, 0.0}});
    std::vector<dw::DynamicDelaunayGraph::PointId> ids;
    for (const Batch& b : batches) {
      std::vector<dw::DynamicDelaunayGraph::PointId> out;
      for (std::size_t i : b.out) out.push_back(ids[i]);
      auto t0 = Clock::now();
      double c0 = cpuNow();
      if (!out.empty()) map.remove(out);
      dw_out += since(t0);
      dw_out_cpu += cpuNow() - c0;
      t0 = Clock::now();
      c0 = cpuNow();
      const auto got = map.insert(dw::PointView::fromFloat(b.in.data(), b.in.size() / 3));
      dw_in += since(t0);
      dw_in_cpu += cpuNow() - c0;
      ids.insert(ids.end(), got.begin(), got.end());
      inserted += b.in.size() / 3;
      removed += b.out.size();
    }
  }
  std::printf(
      "\nsliding-window map maintenance, %s scans at voxel %.2f m, range %.0f m, %zu frames (one thread)\n",
      voxel > 0 ? "downsampled" : "full-resolution", voxel, range, batches.size());
  std::printf("%-34s %12s %14s %14s %12s %14s %14s\n", "structure", "inserted", "insert pts/s",
              "(thread cpu)", "removed", "remove pts/s", "(thread cpu)");
  auto rate = [](std::size_t n, double t) { return t > 0 ? double(n) / t : 0.0; };
  auto row = [&](const char* name, double tin, double tin_cpu, std::size_t out, double tout,
                 double tout_cpu) {
    std::printf("%-34s %12zu %14.3g %14.3g %12zu %14.3g %14.3g\n", name, inserted, rate(inserted, tin),
                rate(inserted, tin_cpu), out, rate(out, tout), rate(out, tout_cpu));
  };
  row("dw::DynamicDelaunayGraph", dw_in, dw_in_cpu, removed, dw_out, dw_out_cpu);
#ifdef DW_HAVE_NANOFLANN_PEER
  {
    FloatCloud cloud{&stream};  // the whole stream is there up front; the tree indexes what was added
    nanoflann::KDTreeSingleIndexIncrementalAdaptor<nanoflann::L2_Simple_Adaptor<float, FloatCloud>,
                                                   FloatCloud, 3, std::uint32_t>
        tree(3, cloud);
    double nin = 0, nout = 0, nin_cpu = 0, nout_cpu = 0;
    std::size_t next = 0, tree_removed = 0;
    // Its removal slows down as the tree grows (a few hundred points/s on a full-resolution stream,
    // which would take minutes): removals stop counting after this budget, and the rate is theirs.
    constexpr double kRemovalBudget = 10.0;
    for (const Batch& b : batches) {
      auto t0 = Clock::now();
      double c0 = cpuNow();
      for (std::size_t i : b.out) {
        if (nout + since(t0) > kRemovalBudget) break;
        tree.removePoint(std::uint32_t(i));
        ++tree_removed;
      }
      nout += since(t0);
      nout_cpu += cpuNow() - c0;
      const std::size_t n = b.in.size() / 3;
      t0 = Clock::now();
      c0 = cpuNow();
      if (n) tree.addPoints(std::uint32_t(next), std::uint32_t(next + n - 1));
      nin += since(t0);
      nin_cpu += cpuNow() - c0;
      next += n;
    }
    row("nanoflann " NANOFLANN_VERSION_STRING " incremental", nin, nin_cpu, tree_removed, nout, nout_cpu);
    if (tree_removed < removed)
      std::printf("(nanoflann: %zu of the %zu removals timed, then the %.0f s budget ran out)\n",
                  tree_removed, removed, kRemovalBudget);
  }
#endif
}

/// dw::SlidingWindowOdometry over the scene's scans (0.5 m voxels, range 60 m, one thread): per-frame
/// latency and the drift against the true poses made relative to the first.
/// compact_ratio 0: retired points leave the triangulation each frame; else they stay until they
/// outnumber that share of the live ones (dw::OdometryOptions::compact_ratio).
void benchOdometry(const Scene& s, double compact_ratio) {
  dw::OdometryOptions o;
  o.voxel = 0.5;
  o.max_range = 60.0;
  o.num_threads = 1;
  o.compact_ratio = compact_ratio;
  dw::SlidingWindowOdometry odo(o);
  std::vector<double> ms;
  double worst = 0;
  std::size_t ok = 0;
  std::vector<double> cpu_ms;
  for (std::size_t k = 0; k < s.scans.size(); ++k) {
    const double c0 = cpuNow();
    const dw::FrameResult r =
        odo.registerScan(dw::PointView::fromFloat(s.scans[k].data(), s.scans[k].size() / 3));
    cpu_ms.push_back(1e3 * (cpuNow() - c0));
    ms.push_back(1e3 * r.latency_seconds);
    ok += r.status == dw::FrameStatus::Ok;
    const Eigen::Matrix4d rel = s.truth[0].inverse() * s.truth[k];
    worst = std::max(worst, (r.pose.topRightCorner<3, 1>() - rel.topRightCorner<3, 1>()).norm());
  }
  const dw::OdometryMapStats& st = odo.mapStats();
  std::printf(
      "\nsliding-window odometry, 0.5 m voxels, range 60 m, one thread, %zu frames (%zu ok), compact ratio %g"
      " (%llu compactions)\n",
      s.scans.size(), ok, compact_ratio, static_cast<unsigned long long>(st.compactions));
  std::printf(
      "per-frame ms p50 %.2f p95 %.2f max %.2f (thread cpu p50 %.2f); largest translation drift %.3f m;"
      " map %zu points; walk graph %.1f ms/frame, insert %.3g points/s, remove %.3g points/s\n",
      percentile(ms, 0.5), percentile(ms, 0.95), *std::max_element(ms.begin(), ms.end()),
      percentile(cpu_ms, 0.5), worst, odo.mapSize(), 1e3 * st.graph_seconds / double(s.scans.size()),
      st.insert_seconds > 0 ? double(st.inserted) / st.insert_seconds : 0.0,
      st.remove_seconds > 0 ? double(st.removed) / st.remove_seconds : 0.0);
}

#ifdef DW_HAVE_NANOFLANN_PEER
/// The same odometry with nanoflann 1.12.1's incremental tree as the local map: the same ICP loop,
/// 0.5 m voxel hash (one point per voxel), range bound and constant-velocity prediction as
/// dw::SlidingWindowOdometry, so the two differ only in the nearest-neighbour structure.
class NanoflannOdometry final : public dw::CorrespondenceSearch {
 public:
  std::size_t size() const override { return points_.size() / 3; }
  const float* point(std::size_t i) const override { return &points_[3 * i]; }
  bool nearest(const float q[3], dw::index_t&, std::int32_t& index, float& dist2) const override {
    std::uint32_t i = 0;
    float d = 0;
    if (live_count_ == 0 || tree_.knnSearch(q, 1, &i, &d) != 1) return false;
    index = std::int32_t(i);
    dist2 = d;
    return true;
  }

  /// Registers a scan and updates the map; returns the pose (sensor -> first frame).
  Eigen::Matrix4d registerScan(const std::vector<float>& scan) {
    const std::vector<float> pts =
        dw::voxelDownsample(dw::PointView::fromFloat(scan.data(), scan.size() / 3), 0.5);
    const Eigen::Matrix4d guess = pose_ * velocity_;
    Eigen::Matrix4d pose = pose_;
    if (live_count_ > 0) {
      dw::IcpOptions icp;
      icp.max_correspondence_distance = 1.0;
      icp.max_iterations = 30;
      icp.transformation_epsilon = 1e-8;
      icp.num_threads = 1;
      pose = dw::alignIcp(*this, nullptr, pts.data(), pts.size() / 3, guess, icp, ws_).transform;
    }
    velocity_ = pose_.inverse() * pose;
    pose_ = pose;
    const Eigen::Vector3d c = pose.topRightCorner<3, 1>();
    for (std::size_t i = 0; i < live_.size(); ++i) {
      if (!live_[i]) continue;
      const Eigen::Vector3d p(points_[3 * i], points_[3 * i + 1], points_[3 * i + 2]);
      if ((p - c).squaredNorm() > 60.0 * 60.0) {
        tree_.removePoint(std::uint32_t(i));
        live_[i] = 0, --live_count_;
        voxels_.erase(keys_[i]);
      }
    }
    const std::size_t first = size();
    for (std::size_t i = 0; i < pts.size() / 3; ++i) {
      float p[3];
      for (int r = 0; r < 3; ++r)
        p[r] = float(pose(r, 0) * pts[3 * i] + pose(r, 1) * pts[3 * i + 1] + pose(r, 2) * pts[3 * i + 2] +
                     pose(r, 3));
      std::uint64_t key = 0;
      for (int d = 0; d < 3; ++d)
        key = (key << 21) | (std::uint64_t(std::int64_t(std::floor(double(p[d]) / 0.5))) & ((1u << 21) - 1));
      if (!voxels_.emplace(key, size()).second) continue;
      points_.insert(points_.end(), p, p + 3);
      keys_.push_back(key);
      live_.push_back(1);
      ++live_count_;
    }
    if (size() > first) tree_.addPoints(std::uint32_t(first), std::uint32_t(size() - 1));
    return pose;
  }

 private:
  std::vector<float> points_;
  FloatCloud cloud_{&points_};
  nanoflann::KDTreeSingleIndexIncrementalAdaptor<nanoflann::L2_Simple_Adaptor<float, FloatCloud>, FloatCloud,
                                                 3, std::uint32_t>
      tree_{3, cloud_};
  std::unordered_map<std::uint64_t, std::size_t> voxels_;
  std::vector<std::uint64_t> keys_;
  std::vector<char> live_;
  std::size_t live_count_ = 0;
  dw::IcpWorkspace ws_;
  Eigen::Matrix4d pose_ = Eigen::Matrix4d::Identity(), velocity_ = Eigen::Matrix4d::Identity();
};

void benchNanoflannOdometry(const Scene& s) {
  NanoflannOdometry odo;
  std::vector<double> ms;
  double worst = 0;
  std::vector<double> cpu_ms;
  for (std::size_t k = 0; k < s.scans.size(); ++k) {
    const auto t0 = Clock::now();
    const double c0 = cpuNow();
    const Eigen::Matrix4d pose = odo.registerScan(s.scans[k]);
    cpu_ms.push_back(1e3 * (cpuNow() - c0));
    ms.push_back(1e3 * since(t0));
    const Eigen::Matrix4d rel = s.truth[0].inverse() * s.truth[k];
    worst = std::max(worst, (pose.topRightCorner<3, 1>() - rel.topRightCorner<3, 1>()).norm());
  }
  std::printf("the same odometry over nanoflann " NANOFLANN_VERSION_STRING
              "'s incremental tree: per-frame ms p50 %.2f p95 %.2f max %.2f (thread cpu p50 %.2f); largest"
              " translation drift %.3f m\n",
              percentile(ms, 0.5), percentile(ms, 0.95), *std::max_element(ms.begin(), ms.end()),
              percentile(cpu_ms, 0.5), worst);
}
#endif

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw dw::Error("missing value for " + a);
      return argv[++i];
    };
    if (a == "--map-points")
      o.map_points = dw_apps::parseCount(value(), "--map-points");
    else if (a == "--scan-points")
      o.scan_points = dw_apps::parseCount(value(), "--scan-points");
    else if (a == "--frames")
      o.frames = dw_apps::parseCount(value(), "--frames");
    else if (a == "--threads")
      o.threads = unsigned(dw_apps::parseNonNegative(value(), "--threads"));
    else if (a == "--kitti")
      o.kitti = value();
    else if (a == "--max-distance")
      o.max_distance = dw_apps::parseNonNegative(value(), "--max-distance");
    else if (a == "--seed")
      o.seed = unsigned(dw_apps::parseCount(value(), "--seed"));
    else if (a == "--odometry")
      o.odometry = true;
    else if (a == "--graph-file")
      o.graph_file = value();
    else if (a == "--scan-order") {
      const std::string v = value();
      if (v != "sensor" && v != "random")
        throw dw::Error("--scan-order takes sensor or random, not '" + v + "'");
      o.scan_order = v == "sensor" ? dw_bench::ScanOrder::kSensor : dw_bench::ScanOrder::kRandom;
    } else if (a == "--no-maintenance")
      o.maintenance = false;
    else if (a == "--no-pcl")
      o.pcl = false;
    else
      throw dw::Error("unknown option '" + a + "'");
  }
  if (o.frames < 2) throw dw::Error("--frames must be >= 2");
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  // Line-buffered, so that a run cut short by a timeout still shows the stages it finished.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  try {
    const Options o = parse(argc, argv);
    if (!o.kitti.empty()) {
      Scene k;
      if (makeKitti(o, k)) benchScene(k, o);
    }
    const Scene s = makeSynthetic(o);
    benchScene(s, o);
    if (o.odometry) {
      if (o.maintenance) {
        benchMapMaintenance(s, 0.5, 60.0);
        benchMapMaintenance(s, 0.0, 60.0);
      }
      benchOdometry(s, 0.0);
      benchOdometry(s, 1.0);
#ifdef DW_HAVE_NANOFLANN_PEER
      benchNanoflannOdometry(s);
#endif
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_localize_bench: %s\n", e.what());
    return 1;
  }
}
