// dw_localize_bench: per-frame time of localization against a prior map, one process, side by side:
//   - walk:       the localizer's ICP loop (core/registration/icp.h) over the Delaunay walk, warm starts
//                 within and across frames;
//   - exact peers in the same loop, each a dw::CorrespondenceSearch: nanoflann 1.12.1's static
//                 KDTreeSingleIndexAdaptor (leaf 10), pico_tree's kd_tree (leaf 10) and small_gicp's
//                 KdTree (its defaults); their poses must equal the walk's within 1e-6 relative;
//   - small_gicp's own ICP (point-to-point factor, its Levenberg-Marquardt loop) on the same map from
//                 the same kind of guess, with our distance, iterations and epsilon translated: a
//                 different loop, so compared by time and by error against the true poses;
//   - pcl:        stock pcl::IterativeClosestPoint<PointXYZ, PointXYZ, double> with a prebuilt
//                 pcl::search::KdTree (only in a build with PCL).
// Same scans, same guesses (each method's own constant-velocity prediction), same distance,
// iterations and epsilons; ratios are the peer's time over the walk's. With --odometry it also
// measures the sliding-window map's insert and remove rates (dw::DynamicDelaunayGraph) beside
// nanoflann 1.12.1's KDTreeSingleIndexIncrementalAdaptor on the same stream, and our odometry beside
// the same odometry over nanoflann's incremental tree and small_gicp's over its incremental voxel map;
// ours twice: deleting the points that leave the window every frame (compact ratio 0), and retiring
// them until a compaction (the default).
// A peer whose folder was absent at build time (bench/CMakeLists.txt, DW_PEERS_DIR) prints a line
// saying so instead of its row; the adaptors live in bench/localize_peers/.
//
//   dw_localize_bench [--map-points 2M] [--scan-points 120k] [--frames 10] [--threads 0] [--kitti DIR]
//                     [--max-distance 1] [--odometry] [--no-pcl] [--seed 1] [--graph-file TMP.graph]
//                     [--scan-order sensor|random] [--no-maintenance]
// --threads is the walk's, the exact peers' ICP loop's and small_gicp's (its tree build and its
// reduction, with OpenMP; one thread without). The odometry rows are one thread each.
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
#include "localize_peers/nanoflann_peers.h"
#endif
#ifdef DW_HAVE_PICO_TREE_PEER
#include "localize_peers/pico_tree_search.h"
#endif
#ifdef DW_HAVE_SMALL_GICP_PEER
#include "localize_peers/small_gicp_peers.h"
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
  bool exact = true;  ///< our loop over an exact search: poses must equal the walk's within 1e-6
  std::string note;   ///< why its poses may still differ, printed when they do
  double build_s = 0;
  std::vector<double> frame_ms;
  std::vector<Eigen::Matrix4d> poses;
  double iterations = 0;
};

/// A street sequence has true poses; the KITTI pair registers one scan again and again, truth unknown.
bool isSequence(const Scene& s) {
  return s.truth.size() > 1 && s.truth[1] != s.truth[0];
}

struct FrameFit {
  Eigen::Matrix4d pose;
  int iterations = 0;
};

/// The sequence through `align(k, guess)`: the first guess is the true pose (a KITTI pair: identity),
/// then a constant-velocity prediction from the method's own poses. Times each call.
template <typename Align>
void runSequence(const Scene& s, RunResult& r, Align&& align) {
  Eigen::Matrix4d prev = s.truth[0], vel = Eigen::Matrix4d::Identity();
  const bool sequence = isSequence(s);
  for (std::size_t k = 0; k < s.scans.size(); ++k) {
    const Eigen::Matrix4d guess = sequence ? Eigen::Matrix4d(k == 0 ? s.truth[0] : prev * vel) : s.truth[k];
    const auto t0 = Clock::now();
    const FrameFit fit = align(k, guess);
    r.frame_ms.push_back(1e3 * since(t0));
    r.iterations += fit.iterations;
    r.poses.push_back(fit.pose);
    if (k > 0) vel = prev.inverse() * fit.pose;
    prev = fit.pose;
  }
  r.iterations /= double(s.scans.size());
}

/// Our ICP loop (alignIcp) over `search`.
void runLoop(const dw::CorrespondenceSearch& search, const Scene& s, const Options& o, RunResult& r) {
  dw::IcpWorkspace ws;
  const bool sequence = isSequence(s);
  runSequence(s, r, [&](std::size_t k, const Eigen::Matrix4d& guess) {
    if (!sequence) ws.hints.clear();  // the same scan again: no warm start from the previous answer
    const dw::IcpResult res =
        dw::alignIcp(search, nullptr, s.scans[k].data(), s.scans[k].size() / 3, guess, icpOptions(o), ws);
    return FrameFit{res.transform, res.iterations};
  });
}

/// Our loop over an exact peer's search, built from `args` (its build timed).
template <typename Search, typename... Args>
RunResult runExactPeer(std::string method, const Scene& s, const Options& o, const Args&... args) {
  RunResult r;
  r.method = std::move(method);
  const auto t0 = Clock::now();
  const Search search(args...);
  r.build_s = since(t0);
  runLoop(search, s, o, r);
  return r;
}

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

/// The largest distance between a pose's translation and the true one (the KITTI pair has no truth).
double maxTranslationError(const std::vector<Eigen::Matrix4d>& poses, const Scene& s) {
  double worst = 0;
  for (std::size_t k = 0; k < std::min(poses.size(), s.truth.size()); ++k)
    worst = std::max(worst, (poses[k].topRightCorner<3, 1>() - s.truth[k].topRightCorner<3, 1>()).norm());
  return worst;
}

/// The walk's run: the map graph's build (timed with the search's set-up), its statistics and, with
/// --graph-file, its save and load.
RunResult runWalk(const Scene& s, const Options& o) {
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
  return r;
}

#ifdef DW_HAVE_SMALL_GICP_PEER
/// small_gicp's own registration from its own constant-velocity guesses (its tree build timed).
RunResult runSmallGicpIcp(const Scene& s, const Options& o) {
  RunResult r;
  r.method = std::string(dw_bench::kSmallGicpLabel) + " own ICP";
  r.exact = false;
  const auto t0 = Clock::now();
  const dw_bench::SmallGicpIcp icp(s.map, icpOptions(o));
  r.build_s = since(t0);
  runSequence(s, r, [&](std::size_t k, const Eigen::Matrix4d& guess) {
    const small_gicp::RegistrationResult res = icp.align(s.scans[k], guess);
    return FrameFit{res.T_target_source.matrix(), int(res.iterations)};
  });
  return r;
}
#endif

/// The peers in our loop, each present or skipped with a line, then small_gicp's own ICP.
void runPeers([[maybe_unused]] const Scene& s, [[maybe_unused]] const Options& o,
              [[maybe_unused]] std::vector<RunResult>& runs) {
#ifdef DW_HAVE_NANOFLANN_PEER
  runs.push_back(
      runExactPeer<dw_bench::NanoflannSearch>("nanoflann " NANOFLANN_VERSION_STRING, s, o, s.map, o.threads));
#else
  std::printf("nanoflann 1.12.1 (../shared/peers/nanoflann) not found at build time: skipped\n");
#endif
#ifdef DW_HAVE_PICO_TREE_PEER
  runs.push_back(runExactPeer<dw_bench::PicoTreeSearch>(dw_bench::kPicoTreeLabel, s, o, s.map));
#else
  std::printf("pico_tree 1.0.0+ (../shared/peers/pico_tree) not found at build time: skipped\n");
#endif
#ifdef DW_HAVE_SMALL_GICP_PEER
  runs.push_back(runExactPeer<dw_bench::SmallGicpKdTreeSearch>(
      std::string(dw_bench::kSmallGicpLabel) + " KdTree", s, o, s.map, o.threads));
  runs.back().note =
      "small_gicp's KdTree measures in double: where two map points tie in the float metric of the "
      "others it may take the truly nearer one, and unconverged iterations (the KITTI pair's 30) carry "
      "that difference on";
  runs.push_back(runSmallGicpIcp(s, o));
#else
  std::printf("small_gicp 1.0.1+ (../shared/peers/small_gicp) not found at build time: skipped\n");
#endif
}

#ifdef DW_BENCH_PCL
/// PCL starts each frame where the walk's run did (`walk`), so the frames are the same registrations.
std::vector<Eigen::Matrix4d> walkGuesses(const Scene& s, const std::vector<Eigen::Matrix4d>& walk) {
  std::vector<Eigen::Matrix4d> guesses;
  for (std::size_t k = 0; k < s.scans.size(); ++k) {
    if (!isSequence(s) || k == 0)
      guesses.push_back(s.truth[k]);
    else if (k == 1)
      guesses.push_back(walk[0]);
    else
      guesses.push_back(walk[k - 1] * (walk[k - 2].inverse() * walk[k - 1]));
  }
  return guesses;
}
#endif

void printScene(const Scene& s, const Options& o, const std::vector<RunResult>& runs) {
  std::printf("\n%s, %u threads, max distance %.2f m\n", s.name.c_str(), dw::resolveThreads(o.threads),
              o.max_distance);
#ifdef DW_HAVE_SMALL_GICP_PEER
  if (dw_bench::smallGicpThreads(o.threads) != int(dw::resolveThreads(o.threads)))
    std::printf("(built without OpenMP: small_gicp's tree build and ICP run on one thread)\n");
#endif
  std::printf("%-36s %9s %9s %9s %9s %7s %10s %13s %10s\n", "method", "build s", "p50 ms", "mean ms",
              "max ms", "iters", "ratio p50", "max rel diff", "max err m");
  const double walk_p50 = percentile(runs[0].frame_ms, 0.5);
  std::string mismatched, notes;
  for (const RunResult& r : runs) {
    double mean = 0;
    for (double m : r.frame_ms) mean += m;
    mean /= double(std::max<std::size_t>(1, r.frame_ms.size()));
    const double diff = maxRelativeDifference(r.poses, runs[0].poses);
    if (r.exact && !(diff <= 1e-6)) {
      mismatched += " " + r.method + ";";
      if (!r.note.empty()) notes += "  (" + r.note + ")\n";
    }
    char err[32] = "-";  // against the truth, which the KITTI pair lacks
    if (isSequence(s)) std::snprintf(err, sizeof err, "%.2e", maxTranslationError(r.poses, s));
    std::printf("%-36s %9.3f %9.2f %9.2f %9.2f %7.2f %9.2fx %13.2e %10s\n", r.method.c_str(), r.build_s,
                percentile(r.frame_ms, 0.5), mean, *std::max_element(r.frame_ms.begin(), r.frame_ms.end()),
                r.iterations, percentile(r.frame_ms, 0.5) / walk_p50, diff, err);
  }
  if (mismatched.empty())
    std::printf("exact searches in our loop: poses within 1e-6 relative of the walk's\n");
  else
    std::printf("exact searches in our loop beyond 1e-6 relative of the walk's poses:%s\n%s",
                mismatched.c_str(), notes.c_str());
}

void benchScene(const Scene& s, const Options& o) {
  std::vector<RunResult> runs;
  runs.push_back(runWalk(s, o));
  runPeers(s, o, runs);
#ifdef DW_BENCH_PCL
  if (o.pcl) {
    RunResult r;
    r.method = "PCL ICP + KdTree";
    r.exact = false;  // its own float rounding of the moved scan: 5e-6 on the unconverged KITTI pair
    runPcl(s, o, walkGuesses(s, runs[0].poses), r);
    runs.push_back(std::move(r));
  }
#endif
  printScene(s, o, runs);
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
    dw_bench::FloatCloud cloud{
        &stream};  // the whole stream is there up front; the tree indexes what was added
    dw_bench::NanoIncrementalTree tree(3, cloud);
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

/// dw::SlidingWindowOdometry's ICP settings (OdometryOptions' defaults), on one thread: the peers'
/// odometries use them too.
dw::IcpOptions odometryIcp() {
  dw::IcpOptions icp = dw::OdometryOptions().icp;
  icp.num_threads = 1;
  return icp;
}

/// One odometry's frames: wall and thread-CPU time of each registerScan and its pose (sensor -> first
/// frame).
struct OdometryRun {
  std::string method;
  std::vector<double> ms, cpu_ms;
  std::vector<Eigen::Matrix4d> poses;
};

/// Drift against the true poses made relative to the first (the odometries start at identity, no
/// alignment): the largest translation error and its RMSE over the frames (ATE).
void printOdometryTable(const Scene& s, const std::vector<OdometryRun>& runs) {
  std::printf("%-52s %9s %9s %9s %9s %10s %10s\n", "odometry (one thread)", "p50 ms", "p95 ms", "max ms",
              "cpu p50", "max err m", "ATE m");
  for (const OdometryRun& r : runs) {
    double worst = 0, sum2 = 0;
    for (std::size_t k = 0; k < r.poses.size(); ++k) {
      const Eigen::Matrix4d rel = s.truth[0].inverse() * s.truth[k];
      const double e = (r.poses[k].topRightCorner<3, 1>() - rel.topRightCorner<3, 1>()).norm();
      worst = std::max(worst, e);
      sum2 += e * e;
    }
    std::printf("%-52s %9.2f %9.2f %9.2f %9.2f %10.3f %10.3f\n", r.method.c_str(), percentile(r.ms, 0.5),
                percentile(r.ms, 0.95), *std::max_element(r.ms.begin(), r.ms.end()),
                percentile(r.cpu_ms, 0.5), worst,
                std::sqrt(sum2 / double(std::max<std::size_t>(1, r.poses.size()))));
  }
}

/// dw::SlidingWindowOdometry over the scene's scans (0.5 m voxels, range 60 m, one thread); its time
/// is its own latency_seconds (downsampling included, as in the peers' rows). compact_ratio 0: the
/// points that leave the window leave the triangulation each frame; else they stay until they
/// outnumber that share of the live ones (dw::OdometryOptions::compact_ratio).
OdometryRun runOdometry(const Scene& s, double compact_ratio) {
  dw::OdometryOptions o;
  o.icp = odometryIcp();
  o.voxel = 0.5;
  o.max_range = 60.0;
  o.num_threads = 1;
  o.compact_ratio = compact_ratio;
  dw::SlidingWindowOdometry odo(o);
  OdometryRun run;
  run.method = compact_ratio == 0 ? "walk (dw::SlidingWindowOdometry), delete every frame"
                                  : "walk (dw::SlidingWindowOdometry)";
  std::size_t ok = 0;
  for (std::size_t k = 0; k < s.scans.size(); ++k) {
    const double c0 = cpuNow();
    const dw::FrameResult r =
        odo.registerScan(dw::PointView::fromFloat(s.scans[k].data(), s.scans[k].size() / 3));
    run.cpu_ms.push_back(1e3 * (cpuNow() - c0));
    run.ms.push_back(1e3 * r.latency_seconds);
    run.poses.push_back(r.pose);
    ok += r.status == dw::FrameStatus::Ok;
  }
  const dw::OdometryMapStats& st = odo.mapStats();
  std::printf(
      "\nsliding-window odometry, 0.5 m voxels, range 60 m, one thread, %zu frames (%zu ok), compact ratio %g"
      " (%llu compactions): map %zu points; walk graph %.1f ms/frame, insert %.3g points/s, remove %.3g "
      "points/s\n",
      s.scans.size(), ok, compact_ratio, static_cast<unsigned long long>(st.compactions), odo.mapSize(),
      1e3 * st.graph_seconds / double(s.scans.size()),
      st.insert_seconds > 0 ? double(st.inserted) / st.insert_seconds : 0.0,
      st.remove_seconds > 0 ? double(st.removed) / st.remove_seconds : 0.0);
  return run;
}

/// A peer odometry (registerScan(scan) -> pose) over the scene's scans, timed by wall and thread CPU.
template <typename Odometry>
OdometryRun runPeerOdometry(std::string method, Odometry& odo, const Scene& s) {
  OdometryRun run;
  run.method = std::move(method);
  for (const std::vector<float>& scan : s.scans) {
    const auto t0 = Clock::now();
    const double c0 = cpuNow();
    run.poses.push_back(odo.registerScan(scan));
    run.cpu_ms.push_back(1e3 * (cpuNow() - c0));
    run.ms.push_back(1e3 * since(t0));
  }
  return run;
}

/// Our odometry, then the peers' on the same scans, as one table.
void benchOdometries(const Scene& s) {
  std::vector<OdometryRun> runs{runOdometry(s, 1.0), runOdometry(s, 0.0)};
#ifdef DW_HAVE_NANOFLANN_PEER
  {
    dw_bench::NanoflannOdometry odo(odometryIcp());
    runs.push_back(
        runPeerOdometry("our loop, nanoflann " NANOFLANN_VERSION_STRING " incremental tree", odo, s));
  }
#else
  std::printf("nanoflann 1.12.1 (../shared/peers/nanoflann) not found at build time: its odometry skipped\n");
#endif
#ifdef DW_HAVE_SMALL_GICP_PEER
  const auto icp = dw_bench::SmallGicpSettings::from(odometryIcp());
  for (int offsets : {27, 1}) {
    dw_bench::SmallGicpOdometry odo(0.5, offsets, icp);
    runs.push_back(runPeerOdometry(std::string(dw_bench::kSmallGicpLabel) + " ICP, voxel map, " +
                                       std::to_string(offsets) + (offsets == 1 ? " voxel" : " voxels"),
                                   odo, s));
    if (offsets == 27) std::printf("small_gicp voxel map: %zu points at the end\n", odo.mapPoints());
  }
#else
  std::printf(
      "small_gicp 1.0.1+ (../shared/peers/small_gicp) not found at build time: its odometry skipped\n");
#endif
  printOdometryTable(s, runs);
}

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
      benchOdometries(s);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_localize_bench: %s\n", e.what());
    return 1;
  }
}
