// dw_bench: the Delaunay-walk paper's experiments (Anderson et al. 2022, §5) side by side with the
// exact peers, written as CSV for scripts/plot_benchmarks.py. See docs/benchmarks.md.
//
// Sections (--sections, default all):
//   build   structure build time per data set and method (Qhull-built walk graph vs k-d trees)
//   nn      per-query NN time on an ICP-like query sequence, 1..T threads, exactness vs a reference,
//           walk-count statistics and histograms per start strategy
//   icp     stock pcl::IterativeClosestPoint with each NN method plugged in, over the rotation protocol
//           (-20..20 deg in roll, pitch, yaw), with and without noise on the target; per-run, per-iteration
//           and per-step (NN / SVD / other) times
//   accept  the acceptance ratios on one data set: out-of-the-box ICP vs ICP with the walk estimator
//   scan2scan  real LiDAR frame pairs (scan-to-scan odometry: fast_gicp's pair and two KITTI frames):
//           every structure built inside the timing, since each new scan is a new target (not in the
//           default set)
// GCC 12 reports -Warray-bounds false positives inside Eigen's SSE loads of Vector3f when it inlines
// PCL's SVD transformation estimation (the 16-byte load of a 12-byte vector is masked). GCC judges
// the diagnostic by the state at the system header's location, so this must precede every include.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif

#if !defined(DW_HAVE_NANOFLANN) && __has_include(<nanoflann.hpp>)
#define DW_HAVE_NANOFLANN 1  // the apps target does not probe for it; the header is all it needs
#endif

#include <pcl/registration/icp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "common/icp_estimators.h"
#include "common/query_replay.h"
#include "pcl_delaunay_walk/registration/correspondence_estimation_delaunay_walk.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"
#include "pcl_delaunay_walk/search/kdtree_delaunay_walk.h"

namespace {

using dwb::Cloud;
using dwb::PointT;

constexpr std::size_t kBruteForceMax = 11000;  // the seed ran brute force up to ~11k points

struct Options {
  std::string out = "bench-results";
  std::vector<std::string> datasets;
  std::vector<std::string> methods;
  std::string rotations = "grid";
  unsigned shard = 0, shards = 1;        // --shard K/N: rotations K, K+N, K+2N, ... of the set
  std::set<std::string> only_rotations;  // --only-rotations: labels to keep (empty: all)
  std::vector<int> noise{0, 1};
  double noise_sigma = 0.001;  // relative to the bounding-box diagonal
  int max_iterations = 100;
  std::vector<unsigned> threads{1, 2};
  int nn_iterations = 30;
  int repeats = 3;
  std::set<std::string> sections{"build", "nn", "icp", "accept"};
  std::string accept_dataset = "dragon-100k";
  double scan_max_distance = 1.0;  // metres: ICP's correspondence cut-off for the LiDAR pair
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

void usage() {
  std::cout
      << "usage: dw_bench [--quick] [--out DIR] [--datasets a,b] [--methods a,b] [--rotations "
         "grid|axes|one]\n"
         "                [--shard K/N] [--only-rotations r10p0y-20,...] [--noise 0,1] [--noise-sigma REL] "
         "[--max-iterations N] [--threads 1,2]\n"
         "                [--nn-iterations N] [--repeats N] [--sections build,nn,icp,accept,scan2scan]\n"
         "                [--accept-dataset NAME] [--scan-max-distance M]\n"
         "data sets: teapot-792 dragon-5k bunny-8k dragon-23k bunny-36k lidar-69k dragon-100k dragon-437k\n"
         "           (suffix :half keeps every second point, :quarter every fourth); methods: brute-force "
         "pcl-kdtree nanoflann nanoflann-sorted\n"
         "           pcl-octree walk-zero walk-kd-ann walk-pnn walk-pnn-optimized walk-pnn-prefetch\n"
         "           walk-pnn-optimized-prefetch dw-estimator (walks take @qhull or @incremental for the "
         "builder)\n"
         "--shard K/N: only rotations K, K+N, K+2N, ... (0 <= K < N) of the set, so that N processes\n"
         "           can share one grid (bench/run_grid.sh); round-robin spreads a cut-off run over the "
         "grid\n"
         "--only-rotations: only these rotations of the set (labels as in icp.csv; "
         "tools/device/grid_resume.py)\n"
         "--quick: small data sets, one rotation, 1 repeat, acceptance on dragon-100k (a few minutes)\n";
}

Options parse(int argc, char** argv) {
  Options o;
  bool quick = false;
  std::map<std::string, std::string> kv;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      usage();
      std::exit(0);
    }
    if (a == "--quick") {
      quick = true;
      continue;
    }
    if (a.rfind("--", 0) != 0 || i + 1 >= argc)
      throw dw::Error("dw_bench: bad argument '" + a + "' (see --help)");
    kv[a.substr(2)] = argv[++i];
  }
  if (quick) {
    o.datasets = {"teapot-792", "dragon-5k", "bunny-8k", "dragon-23k"};
    o.rotations = "one";
    o.repeats = 1;
  } else {
    o.datasets = dwb::knownDatasets();
  }
  auto num = [](const std::string& k, const std::string& v) {
    try {
      std::size_t used = 0;
      const double x = std::stod(v, &used);
      if (used != v.size()) throw std::invalid_argument(v);
      return x;
    } catch (const std::exception&) {
      throw dw::Error("dw_bench: --" + k + " needs a number, got '" + v + "'");
    }
  };
  for (const auto& [k, v] : kv) {
    if (k == "out")
      o.out = v;
    else if (k == "datasets")
      o.datasets = split(v);
    else if (k == "methods")
      o.methods = split(v);
    else if (k == "rotations")
      o.rotations = v;
    else if (k == "only-rotations") {
      for (const auto& label : split(v)) o.only_rotations.insert(label);
    } else if (k == "shard") {
      const auto slash = v.find('/');
      if (slash == std::string::npos) throw dw::Error("dw_bench: --shard needs K/N, got '" + v + "'");
      const double kk = num(k, v.substr(0, slash)), nn = num(k, v.substr(slash + 1));
      if (nn < 1 || kk < 0 || kk >= nn || kk != std::floor(kk) || nn != std::floor(nn))
        throw dw::Error("dw_bench: --shard K/N needs integers 0 <= K < N, got '" + v + "'");
      o.shard = unsigned(kk), o.shards = unsigned(nn);
    } else if (k == "noise") {
      o.noise.clear();
      for (const auto& s : split(v)) o.noise.push_back(int(num(k, s)));
    } else if (k == "noise-sigma")
      o.noise_sigma = num(k, v);
    else if (k == "max-iterations")
      o.max_iterations = int(num(k, v));
    else if (k == "threads") {
      o.threads.clear();
      for (const auto& s : split(v)) o.threads.push_back(unsigned(num(k, s)));
    } else if (k == "nn-iterations")
      o.nn_iterations = int(num(k, v));
    else if (k == "repeats")
      o.repeats = int(num(k, v));
    else if (k == "sections") {
      const auto s = split(v);
      o.sections = std::set<std::string>(s.begin(), s.end());
    } else if (k == "accept-dataset")
      o.accept_dataset = v;
    else if (k == "scan-max-distance") {
      o.scan_max_distance = num(k, v);
      if (!(o.scan_max_distance > 0)) throw dw::Error("dw_bench: --scan-max-distance must be > 0");
    } else
      throw dw::Error("dw_bench: unknown option --" + k + " (see --help)");
  }
  if (o.methods.empty()) {
    o.methods = dwb::allMethodNames();
    o.methods.push_back("dw-estimator");
  }
  for (const auto& m : o.methods)
    if (m != "dw-estimator") (void)dwb::makeMethod(m);  // throws for an unknown name, before any work
  if (o.max_iterations < 1 || o.nn_iterations < 1 || o.repeats < 1)
    throw dw::Error("dw_bench: iteration and repeat counts must be >= 1");
  for (unsigned t : o.threads)
    if (t < 1 || t > 256) throw dw::Error("dw_bench: thread counts must be in 1..256");
  for (int n : o.noise)
    if (n != 0 && n != 1) throw dw::Error("dw_bench: --noise takes 0 and/or 1");
  {
    std::set<std::string> labels;  // validates the name and the labels
    for (const auto& r : dwb::rotationSet(o.rotations)) labels.insert(r.label());
    for (const auto& l : o.only_rotations)
      if (!labels.count(l))
        throw dw::Error("dw_bench: rotation '" + l + "' is not in the set '" + o.rotations + "'");
  }
  for (const auto& s : o.sections)
    if (s != "build" && s != "nn" && s != "icp" && s != "accept" && s != "scan2scan")
      throw dw::Error("dw_bench: unknown section '" + s + "'");
  return o;
}

/// A CSV file with a header, flushed per row so a long run can be watched and plotted while it runs.
class Csv {
 public:
  Csv(const std::string& path, const std::string& header) : f_(path) {
    if (!f_) throw dw::Error("dw_bench: cannot write '" + path + "'");
    f_ << header << "\n";
  }
  template <typename... A>
  void row(const A&... a) {
    std::ostringstream s;
    s.precision(9);
    int i = 0;
    ((s << (i++ ? "," : "") << a), ...);
    f_ << s.str() << "\n";
    f_.flush();
  }

 private:
  std::ofstream f_;
};

bool usable(const std::string& method, std::size_t n) {
  if (method == "brute-force" && n > kBruteForceMax) return false;
  if (method == "dw-estimator") return true;
  return dwb::makeMethod(method) != nullptr;
}

/// The NN methods of one target cloud, built once; the four walks share one graph.
struct Built {
  std::map<std::string, std::shared_ptr<dwb::NnMethod>> methods;
  std::map<std::string, double> build_seconds;
};

Built buildAll(const std::vector<float>& xyz, const std::vector<std::string>& names) {
  Built b;
  std::shared_ptr<dwb::WalkNn> first_walk;
  for (const auto& name : names) {
    if (name == "dw-estimator" || !usable(name, xyz.size() / 3)) continue;
    std::shared_ptr<dwb::NnMethod> m = dwb::makeMethod(name);
    auto* walk = dynamic_cast<dwb::WalkNn*>(m.get());
    const auto t0 = dwb::Clock::now();
    if (walk && first_walk)
      walk->shareGraph(*first_walk);
    else
      m->build(xyz);
    // Every walk variant stands on the one graph: each is charged its build, as a user would pay it.
    b.build_seconds[name] = walk && first_walk ? b.build_seconds[first_walk->name()] : dwb::secondsSince(t0);
    if (walk && !first_walk) first_walk = std::static_pointer_cast<dwb::WalkNn>(m);
    b.methods[name] = m;
  }
  return b;
}

std::string reference(std::size_t n) {
#ifdef DW_HAVE_NANOFLANN
  return n <= kBruteForceMax ? "brute-force" : "nanoflann";
#else
  return n <= kBruteForceMax ? "brute-force" : "pcl-kdtree";
#endif
}

void sectionBuild(const Options& o, const dwb::Dataset& d, Csv& csv) {
  std::vector<std::pair<std::string, std::string>> jobs;  // (label, method)
  for (const auto& name : o.methods) {
    if (name == "dw-estimator" || !usable(name, d.size())) continue;
    if (name.rfind("walk-", 0) == 0) continue;  // every walk shares one graph: measured below
    jobs.emplace_back(name, name);
  }
  // The walk graph, by each builder: Qhull (the baseline) and the project's incremental kernel.
  jobs.emplace_back("walk-graph-qhull", "walk-zero@qhull");
  if (dw::haveIncrementalBuilder()) jobs.emplace_back("walk-graph-incremental", "walk-zero@incremental");
  for (const auto& [label, name] : jobs) {
    std::vector<double> secs;
    std::size_t bytes = 0;
    for (int r = 0; r < o.repeats; ++r) {
      auto m = dwb::makeMethod(name);
      const double c0 = dwb::processCpuSeconds();
      m->build(d.xyz);
      secs.push_back(dwb::processCpuSeconds() - c0);
      bytes = m->memoryBytes();
    }
    const double best = *std::min_element(secs.begin(), secs.end());
    csv.row(d.name, d.size(), label, best, bytes);
    std::cout << "  build " << label << ": " << best * 1e3 << " ms CPU\n";
  }
}

void sectionNn(const Options& o, const dwb::Dataset& d, const Built& built, Csv& nn_csv, Csv& hist_csv) {
  const std::string ref_name = reference(d.size());
  auto ref_it = built.methods.find(ref_name);
  std::shared_ptr<dwb::NnMethod> ref;
  if (ref_it != built.methods.end())
    ref = ref_it->second;
  else {
    ref = dwb::makeMethod(ref_name);
    ref->build(d.xyz);
  }
  const dwb::IcpSequence seq = dwb::makeIcpSequence(d.xyz, {10, 10, 10}, *ref, std::size_t(o.nn_iterations));
  const dwb::QueryReplay replay(seq);
  dwb::NnBatch batch;
  std::vector<std::vector<int>> want, got;
  replay.run(*ref, batch, 1, nullptr, &want);
  std::cout << "  nn: " << replay.iterations.size() << " ICP iterations x " << replay.per_iteration
            << " queries\n";
  for (const auto& [name, m] : built.methods) {
    std::vector<std::uint32_t> steps;
    replay.run(*m, batch, 1, &steps, &got);
    std::size_t wrong = 0;
    for (std::size_t t = 0; t < got.size(); ++t)
      wrong += dwb::countWrong(d.xyz, replay.iterations[t].data(), replay.per_iteration, got[t], want[t]);
    double mean_steps = 0, p99 = 0, max_steps = 0;
    if (m->isWalk() && !steps.empty()) {
      std::map<std::uint32_t, std::size_t> hist;
      for (auto s : steps) ++hist[s], mean_steps += s;
      mean_steps /= double(steps.size());
      std::vector<std::uint32_t> sorted(steps);
      std::sort(sorted.begin(), sorted.end());
      p99 = sorted[sorted.size() * 99 / 100];
      max_steps = sorted.back();
      for (const auto& [s, c] : hist) hist_csv.row(d.name, name, s, c);
    }
    for (unsigned threads : o.threads) {
      std::vector<double> secs, cpu;
      for (int r = 0; r < o.repeats; ++r) {
        const auto t0 = dwb::Clock::now();
        const double c0 = dwb::processCpuSeconds();
        replay.run(*m, batch, threads);
        cpu.push_back(dwb::processCpuSeconds() - c0);
        secs.push_back(dwb::secondsSince(t0));
      }
      const double s = *std::min_element(secs.begin(), secs.end());
      const double c = *std::min_element(cpu.begin(), cpu.end());
      const double ns = s * 1e9 / double(replay.numQueries());
      const double ns_cpu = c * 1e9 / double(replay.numQueries());
      nn_csv.row(d.name, d.size(), name, threads, replay.numQueries(), replay.iterations.size(), s, ns,
                 ns_cpu, m->isWalk() ? mean_steps : -1.0, m->isWalk() ? mean_steps + 1.0 : -1.0,
                 m->isWalk() ? p99 : -1.0, m->isWalk() ? max_steps : -1.0, wrong, ref_name);
      std::cout << "  nn " << name << " x" << threads << ": " << ns << " ns/query (cpu " << ns_cpu << ")"
                << (m->isWalk() ? ", mean walk " + std::to_string(mean_steps) : std::string()) << ", wrong "
                << wrong << "\n";
    }
  }
}

struct IcpRun {
  int iterations = 0;
  bool converged = false;
  double align = 0, cpu = 0, nn = 0, svd = 0, rot_err = 0, trans_err = 0;
  std::vector<double> iter_seconds, iter_nn, iter_svd;
};

/// One align() of stock ICP with the named NN method plugged in. Structures are prebuilt (their build
/// time is reported on its own), so this is the registration time proper.
IcpRun runIcp(const std::string& method, const Built& built, pcl::search::DelaunayWalk<PointT>::Ptr walk,
              const Cloud::Ptr& source, const Cloud::Ptr& target, const Eigen::Matrix4d& truth,
              int max_iterations) {
  dwb::IterationClock clock;
  pcl::IterativeClosestPoint<PointT, PointT, float> icp;
  dwb::configureIcp(icp, max_iterations);
  icp.setTransformationEstimation(std::make_shared<dwb::TimedSvd>(&clock));
  pcl::search::KdTree<PointT>::Ptr never_built(new pcl::search::KdTree<PointT>);
  if (method == "pcl-kdtree") {
    // The stock path: PCL's own estimator and FLANN tree (prebuilt, so align() does not rebuild it).
    auto tree = std::make_shared<pcl::search::KdTree<PointT>>();
    tree->setInputCloud(target);
    icp.setCorrespondenceEstimation(std::make_shared<dwb::TimedStockCorrespondenceEstimation>(&clock));
    icp.setSearchMethodTarget(tree, true);
  } else if (method == "dw-estimator") {
    // The project's drop-in: its estimator shares the prebuilt walk with a KdTreeDelaunayWalk.
    using CE = pcl::registration::CorrespondenceEstimationDelaunayWalk<PointT, PointT, float>;
    class TimedCE : public CE {
     public:
      TimedCE(const CE::WalkSearchPtr& w, dwb::IterationClock* c) : CE(w), clock_(c) {}
      void determineCorrespondences(pcl::Correspondences& corr, double max_distance) override {
        clock_->nn_begin.push_back(dwb::Clock::now());
        const auto t0 = dwb::Clock::now();
        CE::determineCorrespondences(corr, max_distance);
        clock_->nn_seconds.push_back(dwb::secondsSince(t0));
      }

     private:
      dwb::IterationClock* clock_;
    };
    auto ce = std::make_shared<TimedCE>(walk, &clock);
    ce->setNumberOfThreads(1);
    icp.setCorrespondenceEstimation(ce);
    icp.setSearchMethodTarget(std::make_shared<pcl::search::KdTreeDelaunayWalk<PointT>>(walk), true);
  } else {
    auto ce = std::make_shared<dwb::MethodCorrespondenceEstimation>(built.methods.at(method), &clock, 1);
    icp.setCorrespondenceEstimation(ce);
    icp.setSearchMethodTarget(never_built, true);
  }
  icp.setInputSource(source);
  icp.setInputTarget(target);
  Cloud out;
  const double c0 = dwb::processCpuSeconds();
  clock.begin();
  icp.align(out);
  clock.end();
  IcpRun r;
  r.cpu = dwb::processCpuSeconds() - c0;
  r.iterations = int(clock.iterations());
  r.converged = icp.hasConverged();
  r.align = clock.totalSeconds();
  r.nn = clock.sumNn();
  r.svd = clock.sumSvd();
  for (std::size_t i = 0; i < clock.iterations(); ++i) {
    r.iter_seconds.push_back(clock.iterationSeconds(i));
    r.iter_nn.push_back(clock.nn_seconds[i]);
    r.iter_svd.push_back(i < clock.svd_seconds.size() ? clock.svd_seconds[i] : 0.0);
  }
  dwb::poseError(truth, icp.getFinalTransformation().cast<double>(), r.rot_err, r.trans_err);
  return r;
}

void sectionIcp(const Options& o, const dwb::Dataset& d, Csv& run_csv, Csv& iter_csv) {
  const auto all_rotations = dwb::rotationSet(o.rotations);
  // Per-iteration times (Fig. 14) are traced for one rotation per data set: 10/10/10 degrees (the NN
  // section's sequence) when the set has it, else its first; whichever shard holds it writes them.
  std::size_t traced = 0;
  for (std::size_t i = 0; i < all_rotations.size(); ++i)
    if (all_rotations[i].label() == dwb::Rotation{10, 10, 10}.label()) traced = i;
  std::vector<dwb::Rotation> rotations;
  std::vector<bool> trace;
  for (std::size_t i = o.shard; i < all_rotations.size(); i += o.shards) {
    if (!o.only_rotations.empty() && !o.only_rotations.count(all_rotations[i].label())) continue;
    rotations.push_back(all_rotations[i]);
    trace.push_back(i == traced);
  }
  const Eigen::Vector3d c = dwb::centroid(d.xyz);
  const double sigma = o.noise_sigma * dwb::bboxDiagonal(d.xyz);
  for (int noisy : o.noise) {
    const std::vector<float> target_xyz = noisy ? dwb::withNoise(d.xyz, sigma) : d.xyz;
    const Cloud::Ptr target = dwb::toCloud(target_xyz);
    const Built built = buildAll(target_xyz, o.methods);
    pcl::search::DelaunayWalk<PointT>::Ptr walk;
    double walk_build = 0;
    if (std::find(o.methods.begin(), o.methods.end(), "dw-estimator") != o.methods.end()) {
      walk = std::make_shared<pcl::search::DelaunayWalk<PointT>>();
      const auto t0 = dwb::Clock::now();
      walk->setInputCloud(target);
      walk_build = dwb::secondsSince(t0);
    }
    for (std::size_t ri = 0; ri < rotations.size(); ++ri) {
      const dwb::Rotation& rot = rotations[ri];
      const Eigen::Matrix4d m = rot.about(c);
      const Cloud::Ptr source = dwb::toCloud(dwb::transformed(d.xyz, m));
      const Eigen::Matrix4d truth = m.inverse();
      for (const auto& name : o.methods) {
        if (!usable(name, d.size())) continue;
        const IcpRun r = runIcp(name, built, walk, source, target, truth, o.max_iterations);
        const double build = name == "dw-estimator" ? walk_build : built.build_seconds.at(name);
        run_csv.row(d.name, d.size(), noisy, rot.label(), name, r.iterations, r.converged ? 1 : 0, r.align,
                    r.nn, r.svd, r.align - r.nn - r.svd, build, r.rot_err, r.trans_err, r.cpu);
        if (trace[ri])
          for (std::size_t i = 0; i < r.iter_seconds.size(); ++i)
            iter_csv.row(d.name, noisy, rot.label(), name, i, r.iter_seconds[i], r.iter_nn[i], r.iter_svd[i]);
        std::cout << "  icp " << (noisy ? "noisy " : "") << rot.label() << " " << name << ": " << r.iterations
                  << " it, " << r.align * 1e3 << " ms (nn " << r.nn * 1e3 << "), rot err " << r.rot_err
                  << " deg\n";
      }
    }
  }
}

void sectionAccept(const Options& o, Csv& csv) {
  const dwb::Dataset d = dwb::loadDataset(o.accept_dataset);
  std::cout << "== acceptance on " << d.name << " (" << d.size()
            << " points), rotation r10p10y10, 1 thread\n";
  const Eigen::Matrix4d m = dwb::Rotation{10, 10, 10}.about(dwb::centroid(d.xyz));
  const Cloud::Ptr target = dwb::toCloud(d.xyz);
  const Cloud::Ptr source = dwb::toCloud(dwb::transformed(d.xyz, m));
  Cloud out;
  // Stock ICP with the project's estimator: the graph is built once by the walk search (timed), then
  // every align() reuses it (the search keeps its graph while the target's content is unchanged).
  using CE = pcl::registration::CorrespondenceEstimationDelaunayWalk<PointT, PointT, float>;
  auto walk = std::make_shared<pcl::search::DelaunayWalk<PointT>>();
  std::vector<double> builds, builds_cpu;
  for (int r = 0; r < o.repeats; ++r) {
    auto w = std::make_shared<pcl::search::DelaunayWalk<PointT>>();
    const auto tb = dwb::Clock::now();
    const double c0 = dwb::processCpuSeconds();
    w->setInputCloud(target);
    builds_cpu.push_back(dwb::processCpuSeconds() - c0);
    builds.push_back(dwb::secondsSince(tb));
    if (r == 0) walk = w;
  }
  // Runs alternate between the two so that load from other processes hits both alike; the minimum
  // of the repeats is the least disturbed run.
  std::vector<double> stock, ours, stock_cpu, ours_cpu;
  int stock_it = 0;
  std::size_t ours_it = 0;
  for (int r = 0; r < o.repeats; ++r) {
    {  // out of the box: what a PCL user runs today (align() builds its FLANN tree itself)
      pcl::IterativeClosestPoint<PointT, PointT, float> icp;
      dwb::configureIcp(icp, o.max_iterations);
      dwb::IterationClock clock;
      icp.setCorrespondenceEstimation(std::make_shared<dwb::TimedStockCorrespondenceEstimation>(&clock));
      icp.setInputSource(source);
      icp.setInputTarget(target);
      const auto t0 = dwb::Clock::now();
      const double c0 = dwb::processCpuSeconds();
      icp.align(out);
      stock_cpu.push_back(dwb::processCpuSeconds() - c0);
      stock.push_back(dwb::secondsSince(t0));
      stock_it = int(clock.iterations());
    }
    {
      pcl::IterativeClosestPoint<PointT, PointT, float> icp;
      dwb::configureIcp(icp, o.max_iterations);
      auto ce = std::make_shared<CE>(walk);
      ce->setNumberOfThreads(1);
      icp.setCorrespondenceEstimation(ce);
      icp.setSearchMethodTarget(std::make_shared<pcl::search::KdTreeDelaunayWalk<PointT>>(walk));
      icp.setInputSource(source);
      icp.setInputTarget(target);
      const auto t0 = dwb::Clock::now();
      const double c0 = dwb::processCpuSeconds();
      icp.align(out);
      ours_cpu.push_back(dwb::processCpuSeconds() - c0);
      ours.push_back(dwb::secondsSince(t0));
      ours_it = ce->getStatistics().size();
    }
  }
  const double s = *std::min_element(stock.begin(), stock.end());
  const double w = *std::min_element(ours.begin(), ours.end());
  const double build = *std::min_element(builds.begin(), builds.end());
  auto least = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
  const double sc = least(stock_cpu), wc = least(ours_cpu), bc = least(builds_cpu);
  csv.row(d.name, d.size(), "stock-icp-kdtree", s, 0.0, stock_it, 0, sc, 0.0);
  csv.row(d.name, d.size(), "icp-walk-estimator-excl-build", w, 0.0, ours_it, walk->getNumberOfBuilds(), wc,
          0.0);
  csv.row(d.name, d.size(), "icp-walk-estimator-incl-build", w + build, build, ours_it,
          walk->getNumberOfBuilds(), wc + bc, bc);
  std::cout << "  stock ICP (KdTree) " << s << " s (" << stock_it << " it); with walk estimator " << w
            << " s excl. build (" << s / w << "x), " << w + build << " s incl. build (" << s / (w + build)
            << "x); graph builds by the shared walk: " << walk->getNumberOfBuilds() << "\n  CPU time: stock "
            << sc << " s, walk " << wc << " s excl. build (" << sc / wc << "x), " << wc + bc
            << " s incl. build (" << sc / (wc + bc) << "x)\n";
}

/// The LiDAR pair's reference transform (fast_gicp's relative.txt: target ~ T source), 4x4 text.
Eigen::Matrix4d readTransform(const std::string& path) {
  std::ifstream f(path);
  Eigen::Matrix4d t;
  for (int i = 0; i < 16; ++i)
    if (!(f >> t(i / 4, i % 4))) throw dw::Error("dw_bench: cannot read a 4x4 matrix from '" + path + "'");
  return t;
}

/// A LiDAR frame without its no-return points: the sensor writes them at exactly (0, 0, 0) (about 5,000
/// per frame here), and left in both frames they match each other at distance 0 and pin ICP to the
/// identity (measured: 0.56 of the pair's 0.62 degrees left unrecovered).
/// A LiDAR frame as PCL floats: PCD through PCL, KITTI .bin through the core reader. No-return points
/// (exactly (0, 0, 0)) are dropped: they would match each other at distance 0 and pin ICP.
Cloud::Ptr loadScan(const std::string& file) {
  const std::vector<float> all = dwb::loadFiniteXyz(dwb::findDataFile("scans", file));
  std::vector<float> xyz;
  xyz.reserve(all.size());
  for (std::size_t i = 0; i + 2 < all.size(); i += 3)
    if (all[i] != 0.f || all[i + 1] != 0.f || all[i + 2] != 0.f) xyz.insert(xyz.end(), &all[i], &all[i] + 3);
  return dwb::toCloud(xyz);
}

/// One scan-to-scan case: source registered onto target (target ~ T * source). Pairs without a
/// reference transform are compared against the stock ICP's result instead (every variant searches
/// exactly, so they should all land on the same pose).
struct ScanPair {
  const char* name;
  const char* target;
  const char* source;
  const char* truth;  // nullptr: none shipped
};

/// Scan-to-scan odometry on real LiDAR frame pairs: each new scan is a new target, so every structure
/// is built inside the timing, and the walk's graph build (20-150x a k-d tree's) is paid on every frame.
/// Same ICP settings for all (max correspondence distance, iterations, epsilons); identity initial
/// guess.
void sectionScan2Scan(const Options& o, Csv& csv) {
  const ScanPair pairs[] = {
      {"fastgicp", "fastgicp_251370668.pcd", "fastgicp_251371071.pcd", "fastgicp_relative.txt"},
      {"kitti", "kitti_000000.bin", "kitti_000001.bin", nullptr},
  };
  using CE = pcl::registration::CorrespondenceEstimationDelaunayWalk<PointT, PointT, float>;
  const std::vector<std::string> variants = {"stock-icp-kdtree", "icp-nanoflann", "icp-walk-pnn-optimized",
                                             "icp-walk-estimator"};
  for (const ScanPair& pair : pairs) {
    const Cloud::Ptr target = loadScan(pair.target);
    const Cloud::Ptr source = loadScan(pair.source);
    Eigen::Matrix4d reference = Eigen::Matrix4d::Identity();
    bool have_reference = pair.truth != nullptr;
    if (have_reference) reference = readTransform(dwb::findDataFile("scans", pair.truth));
    std::vector<float> target_xyz;
    for (const auto& p : target->points) target_xyz.insert(target_xyz.end(), {p.x, p.y, p.z});
    std::cout << "== scan-to-scan " << pair.name << ": source " << source->size() << " -> target "
              << target->size() << " points, max correspondence distance " << o.scan_max_distance
              << " m, error against " << (have_reference ? "the reference transform" : "the stock ICP's pose")
              << "\n";
    for (const auto& v : variants) {
      if (v == "icp-nanoflann" && !dwb::makeMethod("nanoflann")) continue;
      double best_cpu = 1e300, best_build = 0, best_wall = 0;
      Eigen::Matrix4d best_pose = Eigen::Matrix4d::Identity();
      int iterations = 0;
      bool converged = false;
      for (int r = 0; r < o.repeats; ++r) {
        pcl::IterativeClosestPoint<PointT, PointT, float> icp;
        dwb::configureIcp(icp, o.max_iterations);
        icp.setMaxCorrespondenceDistance(o.scan_max_distance);
        dwb::IterationClock clock;
        const auto t0 = dwb::Clock::now();
        const double c0 = dwb::processCpuSeconds();
        double build = 0;
        std::shared_ptr<CE> walk_ce;
        if (v == "stock-icp-kdtree") {
          // What a PCL user runs today: align() builds its FLANN tree itself.
          icp.setCorrespondenceEstimation(std::make_shared<dwb::TimedStockCorrespondenceEstimation>(&clock));
        } else if (v == "icp-walk-estimator") {
          auto walk = std::make_shared<pcl::search::DelaunayWalk<PointT>>();
          walk->setInputCloud(target);
          build = dwb::processCpuSeconds() - c0;
          walk_ce = std::make_shared<CE>(walk);
          walk_ce->setNumberOfThreads(1);
          icp.setCorrespondenceEstimation(walk_ce);
          icp.setSearchMethodTarget(std::make_shared<pcl::search::KdTreeDelaunayWalk<PointT>>(walk), true);
        } else {
          std::shared_ptr<dwb::NnMethod> m =
              dwb::makeMethod(v == "icp-nanoflann" ? "nanoflann" : "walk-pnn-optimized");
          m->build(target_xyz);
          build = dwb::processCpuSeconds() - c0;
          icp.setCorrespondenceEstimation(
              std::make_shared<dwb::MethodCorrespondenceEstimation>(m, &clock, 1));
          icp.setSearchMethodTarget(std::make_shared<pcl::search::KdTree<PointT>>(), true);
        }
        icp.setInputSource(source);
        icp.setInputTarget(target);
        Cloud out;
        icp.align(out);
        const double cpu = dwb::processCpuSeconds() - c0;
        if (cpu < best_cpu) {
          best_cpu = cpu, best_build = build, best_wall = dwb::secondsSince(t0);
          converged = icp.hasConverged();
          iterations = walk_ce ? int(walk_ce->getStatistics().size()) : int(clock.iterations());
          best_pose = icp.getFinalTransformation().cast<double>();
        }
      }
      if (!have_reference && v == "stock-icp-kdtree") reference = best_pose;  // the others are compared to it
      double rot_err = 0, trans_err = 0;
      dwb::poseError(reference, best_pose, rot_err, trans_err);
      csv.row(pair.name, have_reference ? "reference" : "stock", v, source->size(), target->size(),
              o.scan_max_distance, iterations, converged ? 1 : 0, best_cpu, best_build, best_wall, rot_err,
              trans_err);
      std::cout << "  " << v << ": " << best_cpu * 1e3 << " ms CPU incl. build (build " << best_build * 1e3
                << " ms), " << iterations << " iterations, rot err " << rot_err << " deg, trans err "
                << trans_err << " m\n";
    }
  }
}

std::string cpuModel() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::cout << std::unitbuf;  // progress shows up in logs as it happens
    const Options o = parse(argc, argv);
    if (std::system(("mkdir -p '" + o.out + "'").c_str()) != 0)
      throw dw::Error("dw_bench: cannot create " + o.out);
    {
      Csv meta(o.out + "/meta.csv", "key,value");
      meta.row("cpu", "\"" + cpuModel() + "\"");
      meta.row("hardware_threads", std::thread::hardware_concurrency());
      meta.row("rotations", o.rotations);
      meta.row("shard", std::to_string(o.shard) + "/" + std::to_string(o.shards));
      meta.row("max_iterations", o.max_iterations);
      meta.row("noise_sigma_rel_bbox_diagonal", o.noise_sigma);
      meta.row("repeats", o.repeats);
      meta.row("compiler", std::string("\"") + __VERSION__ + "\"");
    }
    const bool any_data = o.sections.count("build") || o.sections.count("nn") || o.sections.count("icp");
    std::unique_ptr<Csv> build_csv, nn_csv, hist_csv, icp_csv, iter_csv, accept_csv;
    if (o.sections.count("build"))
      build_csv = std::make_unique<Csv>(o.out + "/build.csv", "dataset,points,method,seconds,bytes");
    if (o.sections.count("nn")) {
      nn_csv = std::make_unique<Csv>(
          o.out + "/nn.csv",
          "dataset,points,method,threads,queries,icp_iterations,seconds,ns_per_query,cpu_ns_per_query,"
          "mean_steps,mean_visited,p99_steps,max_steps,wrong,reference");
      hist_csv = std::make_unique<Csv>(o.out + "/walk_hist.csv", "dataset,method,steps,count");
    }
    if (o.sections.count("icp")) {
      icp_csv = std::make_unique<Csv>(
          o.out + "/icp.csv",
          "dataset,points,noise,rotation,method,iterations,converged,align_seconds,"
          "nn_seconds,svd_seconds,other_seconds,build_seconds,rot_err_deg,trans_err,cpu_seconds");
      iter_csv = std::make_unique<Csv>(
          o.out + "/icp_iter.csv", "dataset,noise,rotation,method,iteration,seconds,nn_seconds,svd_seconds");
    }
    if (any_data) {
      for (const auto& name : o.datasets) {
        const dwb::Dataset d = dwb::loadDataset(name);
        std::cout << "== " << d.name << ": " << d.size() << " points (" << d.source << ")\n";
        if (build_csv) sectionBuild(o, d, *build_csv);
        if (nn_csv) {
          const Built built = buildAll(d.xyz, o.methods);
          sectionNn(o, d, built, *nn_csv, *hist_csv);
        }
        if (icp_csv) sectionIcp(o, d, *icp_csv, *iter_csv);
      }
    }
    if (o.sections.count("accept")) {
      accept_csv = std::make_unique<Csv>(o.out + "/accept.csv",
                                         "dataset,points,variant,seconds,build_seconds,iterations,graph_"
                                         "builds,cpu_seconds,cpu_build_seconds");
      sectionAccept(o, *accept_csv);
    }
    if (o.sections.count("scan2scan")) {
      Csv scan_csv(o.out + "/scan2scan.csv",
                   "pair,error_against,variant,source_points,target_points,max_distance,iterations,converged,"
                   "cpu_seconds,build_cpu_seconds,wall_seconds,rot_err_deg,trans_err");
      sectionScan2Scan(o, scan_csv);
    }
    std::cout << "results in " << o.out << "/\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
}
