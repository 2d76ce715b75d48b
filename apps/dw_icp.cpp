// dw_icp: registers a source cloud onto a target with ICP whose correspondences come from the
// Delaunay walk, and prints the transform, fitness, iterations and a timing breakdown. With --compare
// it runs stock pcl::IterativeClosestPoint + KdTree on the same input and prints both side by side.
//
//   dw_icp source target [--max-iterations N] [--max-distance D] [--epsilon E] [--fitness-epsilon E]
//          [--voxel L] [--rotate R P Y] [--translate X Y Z] [--strategy zero|kd-ann|pnn|pnn-optimized]
//          [--threads N] [--graph target.graph] [--save-graph out.graph] [--reciprocal]
//          [--tie-break kd-tree|lowest-index] [--compare]
//
// --rotate/--translate move the source first (degrees, roll-pitch-yaw), e.g. to match a model to
// itself as in the seed's protocol. Clouds: .pcd, .ply, KITTI .bin, .las, .laz (two LAS/LAZ tiles
// run in the target's origin frame, printed as "LAS origin"). Timings are wall-clock, single run.
// PCL's SVD transformation estimation, instantiated here, trips GCC 12 false positives inside Eigen.
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#include <pcl/common/transforms.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>
#include <pcl/registration/correspondence_estimation.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/transformation_estimation_svd.h>
#include <pcl/search/kdtree.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "core/util/file_header_check.h"
#include "las_cloud.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#include "pcl_delaunay_walk/registration/icp_delaunay_walk.h"

namespace {

using P = pcl::PointXYZ;
using Cloud = pcl::PointCloud<P>;
using Matrix4 = Eigen::Matrix4f;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

bool endsWith(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

Cloud::Ptr loadCloud(const std::string& path) {
  if (!std::ifstream(path).good()) throw dw::Error("cannot open '" + path + "'");
  if (endsWith(path, ".gz")) throw dw::Error("'" + path + "' is compressed: gunzip it first");
  Cloud::Ptr cloud(new Cloud);
  if (endsWith(path, ".pcd")) {
    dw::checkPointFileHeader(path);  // PCL 1.13 crashes on some malformed headers (robustness.md)
    if (pcl::io::loadPCDFile(path, *cloud) < 0) throw dw::Error("'" + path + "' is not a readable PCD file");
    return cloud;
  }
  const std::vector<double> xyz = dw::readPointsXyz(path);
  cloud->resize(xyz.size() / 3);
  for (std::size_t i = 0; i < cloud->size(); ++i)
    (*cloud)[i] = P(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2]));
  return cloud;
}

/// Wraps a transformation estimator and accumulates the time spent in it (the "TE" column).
class TimedEstimation : public pcl::registration::TransformationEstimation<P, P, float> {
 public:
  using Base = pcl::registration::TransformationEstimation<P, P, float>;

  void estimateRigidTransformation(const Cloud& s, const Cloud& t, Matrix4& m) const override {
    const auto t0 = Clock::now();
    inner_.estimateRigidTransformation(s, t, m);
    seconds_ += since(t0);
  }
  void estimateRigidTransformation(const Cloud& s, const pcl::Indices& is, const Cloud& t,
                                   Matrix4& m) const override {
    const auto t0 = Clock::now();
    inner_.estimateRigidTransformation(s, is, t, m);
    seconds_ += since(t0);
  }
  void estimateRigidTransformation(const Cloud& s, const pcl::Indices& is, const Cloud& t,
                                   const pcl::Indices& it, Matrix4& m) const override {
    const auto t0 = Clock::now();
    inner_.estimateRigidTransformation(s, is, t, it, m);
    seconds_ += since(t0);
  }
  void estimateRigidTransformation(const Cloud& s, const Cloud& t, const pcl::Correspondences& c,
                                   Matrix4& m) const override {
    const auto t0 = Clock::now();
    inner_.estimateRigidTransformation(s, t, c, m);
    seconds_ += since(t0);
  }
  double total() const { return seconds_; }

 private:
  pcl::registration::TransformationEstimationSVD<P, P, float> inner_;
  mutable double seconds_ = 0.0;
};

/// The stock estimator, timed (the "NN" column of stock ICP).
class TimedStockEstimation : public pcl::registration::CorrespondenceEstimation<P, P, float> {
 public:
  double seconds = 0.0;
  void determineCorrespondences(pcl::Correspondences& c, double max_distance) override {
    const auto t0 = Clock::now();
    pcl::registration::CorrespondenceEstimation<P, P, float>::determineCorrespondences(c, max_distance);
    seconds += since(t0);
  }
};

struct StockIcp : pcl::IterativeClosestPoint<P, P> {
  using pcl::IterativeClosestPoint<P, P>::nr_iterations_;
};
struct WalkIcp : pcl::IterativeClosestPointDelaunayWalk<P, P> {
  using pcl::IterativeClosestPointDelaunayWalk<P, P>::nr_iterations_;
};

struct Options {
  int max_iterations = 100;
  double max_distance = std::numeric_limits<double>::max();
  double epsilon = 1e-11;
  double fitness_epsilon = -std::numeric_limits<double>::max();
  float voxel = 0.f;
  double rotate[3] = {0, 0, 0};
  float translate[3] = {0, 0, 0};
  dw::StartStrategy strategy = dw::StartStrategy::PnnOptimized;
  unsigned threads = 1;
  std::string graph, save_graph;
  bool reciprocal = false, compare = false;
  pcl::registration::DelaunayWalkTieBreak tie_break = pcl::registration::DelaunayWalkTieBreak::KdTreeOrder;
};

template <typename Icp>
void configure(Icp& icp, const Options& o) {
  icp.setMaximumIterations(o.max_iterations);
  icp.setMaxCorrespondenceDistance(o.max_distance);
  icp.setTransformationEpsilon(o.epsilon);
  icp.setEuclideanFitnessEpsilon(o.fitness_epsilon);
  icp.setUseReciprocalCorrespondences(o.reciprocal);
}

struct Report {
  Matrix4 transform;
  int iterations = 0;
  bool converged = false;
  double fitness = 0, align_s = 0, index_s = 0, nn_s = 0, te_s = 0, fitness_s = 0;
};

void printMatrix(const Matrix4& m) {
  for (int r = 0; r < 4; ++r)
    std::printf("  %12.8f %12.8f %12.8f %12.8f\n", m(r, 0), m(r, 1), m(r, 2), m(r, 3));
}

/// The queries whose nearest target distance two or more target points share, and which one each
/// correspondence took: FLANN keeps the first it visits, so a tie is where a walk that picked the
/// lowest index would leave stock ICP's trajectory.
void reportTies(const WalkIcp& icp) {
  const auto& ties = icp.getCorrespondenceEstimationWalk()->getTies();
  if (ties.empty()) {
    std::printf("exact ties between equidistant targets: none\n");
    return;
  }
  std::size_t broken = 0;
  for (const auto& t : ties) broken += t.chosen != t.lowest ? 1 : 0;
  std::printf(
      "exact ties between equidistant targets: %zu queries (%zu where the k-d tree's pick is not the "
      "lowest index)\n",
      ties.size(), broken);
  const std::size_t shown = std::min<std::size_t>(ties.size(), 8);
  for (std::size_t i = 0; i < shown; ++i) {
    const auto& t = ties[i];
    std::printf("  iter %zu  source %d  d2 %.9g  lowest target %d  chosen %d\n", t.call + 1, t.query,
                t.sqr_distance, t.lowest, t.chosen);
  }
  if (shown < ties.size()) std::printf("  ... %zu more\n", ties.size() - shown);
}

/// The walk's result and per-iteration statistics (queries, mean walk length, widened, NN time).
void reportWalk(const WalkIcp& icp, const Report& w, const Options& o) {
  std::uint64_t steps = 0, queries = 0, widened = 0;
  for (const auto& s : icp.getIterationStatistics()) {
    steps += s.walk_steps;
    queries += s.queries;
    widened += s.widened;
  }
  std::printf("\nDelaunay walk ICP (%s, %u thread%s)\n", dw::toString(o.strategy), o.threads,
              o.threads == 1 ? "" : "s");
  std::printf("transformation:\n");
  printMatrix(w.transform);
  std::printf("fitness %.9g  iterations %d  converged %s\n", w.fitness, w.iterations,
              w.converged ? "yes" : "no");
  std::printf("graph %s: %.3f s (%zu vertices, %zu directed edges)\n",
              o.graph.empty() ? "build" : "load+check", w.index_s, icp.getTargetGraph()->numVertices(),
              icp.getTargetGraph()->numDirectedEdges());
  std::printf("per-iteration walk statistics:\n  iter  queries  mean-walks  widened  tied   NN ms\n");
  int it = 0;
  for (const auto& s : icp.getIterationStatistics())
    std::printf("  %4d  %7zu  %10.3f  %7zu  %4zu  %6.2f\n", ++it, s.queries, s.meanWalkSteps(), s.widened,
                s.ties, 1e3 * s.nn_seconds);
  reportTies(icp);
  std::printf("mean walks/query %.3f over %llu queries (%llu widened)\n",
              queries ? double(steps) / queries : 0.0, static_cast<unsigned long long>(queries),
              static_cast<unsigned long long>(widened));
}

/// Without --compare: where align()'s time went.
void reportTiming(const Report& w) {
  std::printf("\ntiming (s): align %.4f = NN %.4f + transformation estimation %.4f + rest %.4f; graph %.4f\n",
              w.align_s, w.nn_s, w.te_s, w.align_s - w.nn_s - w.te_s, w.index_s);
}

/// With --compare: the stock result, the difference of the transforms and the timing table.
void reportComparison(const Report& w, const Report& k) {
  std::printf("\nstock pcl::IterativeClosestPoint + pcl::search::KdTree\ntransformation:\n");
  printMatrix(k.transform);
  std::printf("fitness %.9g  iterations %d  converged %s\n", k.fitness, k.iterations,
              k.converged ? "yes" : "no");
  const float max_diff = (w.transform - k.transform).cwiseAbs().maxCoeff();
  std::printf("\nmax |T_walk - T_stock| = %.3g, iterations %s\n", max_diff,
              w.iterations == k.iterations ? "equal" : "DIFFER");
  const double k_align_wo_index = k.align_s - 2 * k.index_s;  // both builds (see runStock)
  std::printf("\n%-34s %12s %12s %8s\n", "seconds", "walk", "KdTree", "ratio");
  auto row = [](const char* name, double a, double b) {
    std::printf("%-34s %12.4f %12.4f %7.2fx\n", name, a, b, a > 0 ? b / a : 0.0);
  };
  const double k_nn_wo_index = k.nn_s - k.index_s;  // less the rebuild inside its first call
  row("NN search (all iterations)", w.nn_s, k_nn_wo_index);
  row("NN search per iteration", w.iterations ? w.nn_s / w.iterations : 0,
      k.iterations ? k_nn_wo_index / k.iterations : 0);
  row("transformation estimation", w.te_s, k.te_s);
  row("rest of align()", w.align_s - w.nn_s - w.te_s, k.align_s - k.nn_s - k.te_s - k.index_s);
  row("index build (graph / one k-d tree)", w.index_s, k.index_s);
  row("align() (KdTree: incl. its build)", w.align_s, k.align_s);
  row("align() excl. any index build", w.align_s, k_align_wo_index);
  row("align() + index build", w.align_s + w.index_s, k.align_s);
  row("getFitnessScore()", w.fitness_s, k.fitness_s);
}

void usage() {
  std::fprintf(stderr,
               "usage: dw_icp source target [--max-iterations N] [--max-distance D] [--epsilon E]\n"
               "              [--fitness-epsilon E] [--voxel L] [--rotate R P Y] [--translate X Y Z]\n"
               "              [--strategy zero|kd-ann|pnn|pnn-optimized] [--threads N] [--graph G]\n"
               "              [--save-graph G] [--reciprocal] [--tie-break kd-tree|lowest-index]\n"
               "              [--compare]\n");
}

/// The command line: options into `o`, the two file names into `files`. Returns -1 to go on, else the
/// exit code (0 after --help, 2 on a usage error, reported here).
int parseOptions(int argc, char** argv, Options& o, std::vector<std::string>& files) {
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw dw::Error(a + " needs a value");
        return argv[++i];
      };
      auto number = [&]() {
        const std::string v = value();
        char* end = nullptr;
        const double d = std::strtod(v.c_str(), &end);
        if (end == v.c_str() || *end) throw dw::Error(a + ": '" + v + "' is not a number");
        return d;
      };
      if (a == "--max-iterations")
        o.max_iterations = static_cast<int>(number());
      else if (a == "--max-distance")
        o.max_distance = number();
      else if (a == "--epsilon")
        o.epsilon = number();
      else if (a == "--fitness-epsilon")
        o.fitness_epsilon = number();
      else if (a == "--voxel")
        o.voxel = static_cast<float>(number());
      else if (a == "--rotate")
        for (double& r : o.rotate) r = number();
      else if (a == "--translate")
        for (float& t : o.translate) t = static_cast<float>(number());
      else if (a == "--strategy")
        o.strategy = dw::parseStartStrategy(value());
      else if (a == "--threads")
        o.threads = static_cast<unsigned>(number());
      else if (a == "--graph")
        o.graph = value();
      else if (a == "--save-graph")
        o.save_graph = value();
      else if (a == "--tie-break") {
        const std::string v = value();
        if (v == "kd-tree")
          o.tie_break = pcl::registration::DelaunayWalkTieBreak::KdTreeOrder;
        else if (v == "lowest-index")
          o.tie_break = pcl::registration::DelaunayWalkTieBreak::LowestIndex;
        else
          throw dw::Error("--tie-break: '" + v + "' is not kd-tree or lowest-index");
      } else if (a == "--reciprocal")
        o.reciprocal = true;
      else if (a == "--compare")
        o.compare = true;
      else if (a == "-h" || a == "--help") {
        usage();
        return 0;
      } else if (!a.empty() && a[0] == '-')
        throw dw::Error("unknown option '" + a + "'");
      else
        files.push_back(a);
    }
    if (files.size() != 2) {
      usage();
      return 2;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_icp: %s\n", e.what());
    usage();
    return 2;
  }
  return -1;
}

/// --voxel: both clouds through one VoxelGrid leaf size.
void voxelFilter(Cloud::Ptr& source, Cloud::Ptr& target, const Options& o) {
  if (!o.graph.empty()) throw dw::Error("--voxel changes the target, so a saved --graph cannot match it");
  for (Cloud::Ptr* c : {&source, &target}) {
    Cloud::Ptr f(new Cloud);
    pcl::VoxelGrid<P> vg;
    vg.setInputCloud(*c);
    vg.setLeafSize(o.voxel, o.voxel, o.voxel);
    vg.filter(*f);
    *c = f;
  }
}

/// --rotate / --translate: the source moved by T * Rz * Ry * Rx (degrees).
void moveSource(Cloud::Ptr& source, const Options& o) {
  const double d = M_PI / 180.0;
  const Eigen::Affine3f m = Eigen::Translation3f(o.translate[0], o.translate[1], o.translate[2]) *
                            Eigen::AngleAxisf(float(o.rotate[2] * d), Eigen::Vector3f::UnitZ()) *
                            Eigen::AngleAxisf(float(o.rotate[1] * d), Eigen::Vector3f::UnitY()) *
                            Eigen::AngleAxisf(float(o.rotate[0] * d), Eigen::Vector3f::UnitX());
  Cloud::Ptr moved(new Cloud);
  pcl::transformPointCloud(*source, *moved, m);
  source = moved;
}

/// Two LAS/LAZ tiles: both in the target's frame (las_cloud.h), so georeferenced tiles keep their
/// resolution; the transform is then the one of that frame. A LAS tile beside a PLY/PCD cloud is
/// loaded in world coordinates, the other cloud's frame.
void loadPair(const std::vector<std::string>& files, Cloud::Ptr& source, Cloud::Ptr& target) {
  const bool las_s = dw_apps::isLasPath(files[0]), las_t = dw_apps::isLasPath(files[1]);
  if (las_s && las_t) {
    Eigen::Vector3d os, ot;
    target.reset(new Cloud(dw_apps::loadLasCloud(files[1], ot)));
    source.reset(new Cloud(dw_apps::loadLasCloud(files[0], os)));
    dw_apps::reframe(*source, os, ot);
    dw_apps::printLasOrigin(ot);
    return;
  }
  Eigen::Vector3d world;
  source = las_s ? Cloud::Ptr(new Cloud(dw_apps::loadLasCloud(files[0], world, false))) : loadCloud(files[0]);
  target = las_t ? Cloud::Ptr(new Cloud(dw_apps::loadLasCloud(files[1], world, false))) : loadCloud(files[1]);
}

/// Reads both clouds, applies --voxel and the source motion, and prints their sizes.
void readInputs(const std::vector<std::string>& files, const Options& o, Cloud::Ptr& source,
                Cloud::Ptr& target) {
  loadPair(files, source, target);
  if (o.voxel > 0.f) voxelFilter(source, target, o);
  if (o.rotate[0] != 0 || o.rotate[1] != 0 || o.rotate[2] != 0 || o.translate[0] != 0 ||
      o.translate[1] != 0 || o.translate[2] != 0)
    moveSource(source, o);
  if (source->empty() || target->empty()) throw dw::Error("source and target must not be empty");
  std::printf("source %s: %zu points\ntarget %s: %zu points\n", files[0].c_str(), source->size(),
              files[1].c_str(), target->size());
}

/// Registers with the Delaunay-walk ICP, timing the graph apart from align(), and prints its result

/// Runs align() and getFitnessScore(), timing each, and records the result in r.
template <class Icp>
void alignAndScore(Icp& icp, Report& r) {
  Cloud out;
  const auto t_align = Clock::now();
  icp.align(out);
  r.align_s = since(t_align);
  r.transform = icp.getFinalTransformation();
  r.iterations = icp.nr_iterations_;
  r.converged = icp.hasConverged();
  const auto t_fit = Clock::now();
  r.fitness = icp.getFitnessScore();
  r.fitness_s = since(t_fit);
}

/// and per-iteration walk statistics.
Report runWalk(const Cloud::Ptr& source, const Cloud::Ptr& target, const Options& o) {
  Report w;
  WalkIcp icp;
  configure(icp, o);
  icp.setStartStrategy(o.strategy);
  icp.setNumberOfThreads(o.threads);
  icp.getCorrespondenceEstimationWalk()->setTieBreak(o.tie_break);
  auto te = std::make_shared<TimedEstimation>();
  icp.setTransformationEstimation(te);
  const auto t_index = Clock::now();
  if (!o.graph.empty()) {
    icp.getSearchMethodWalk()->loadGraph(o.graph);
  }
  // Built (or loaded and checked) here, outside align(), so that the two costs can be told apart;
  // align() then finds the target unchanged and keeps the graph.
  icp.getSearchMethodWalk()->setInputCloud(target);
  w.index_s = since(t_index);
  if (!o.save_graph.empty()) icp.getSearchMethodWalk()->saveGraph(o.save_graph);
  icp.setInputSource(source);
  icp.setInputTarget(target);
  alignAndScore(icp, w);
  w.te_s = te->total();
  for (const auto& s : icp.getIterationStatistics()) w.nn_s += s.nn_seconds;
  reportWalk(icp, w, o);
  return w;
}

/// Registers with stock PCL ICP and its KdTree, timing the correspondence search and one tree build.
Report runStock(const Cloud::Ptr& source, const Cloud::Ptr& target, const Options& o) {
  Report k;
  StockIcp stock;
  configure(stock, o);
  auto te2 = std::make_shared<TimedEstimation>();
  auto ce2 = std::make_shared<TimedStockEstimation>();
  stock.setTransformationEstimation(te2);
  stock.setCorrespondenceEstimation(ce2);
  {
    // What one FLANN build of the target costs, measured on its own. A stock align() pays it twice
    // (PCL 1.13): Registration::initCompute builds the tree, then hands it to the correspondence
    // estimation through setSearchMethodTarget, which marks it stale, so the estimation's first
    // call builds it again (inside the timed NN search).
    const auto t0 = Clock::now();
    pcl::search::KdTree<P> probe;
    probe.setInputCloud(target);
    k.index_s = since(t0);
  }
  stock.setInputSource(source);
  stock.setInputTarget(target);
  alignAndScore(stock, k);
  k.nn_s = ce2->seconds;
  k.te_s = te2->total();
  return k;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  std::vector<std::string> files;
  const int parsed = parseOptions(argc, argv, o, files);
  if (parsed >= 0) return parsed;
  try {
    Cloud::Ptr source, target;
    readInputs(files, o, source, target);
    const Report w = runWalk(source, target, o);
    if (!o.compare) {
      reportTiming(w);
      return 0;
    }
    const Report k = runStock(source, target, o);
    reportComparison(w, k);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_icp: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
