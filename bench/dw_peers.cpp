/// \file dw_peers.cpp
/// \brief dw_peers: the exact searches against the 2026 peers side by side in one process (nanoflann
/// 1.12.1 and Debian's 1.4.3, pico_tree, small_gicp's KdTree, PCL's FLANN KdTree where PCL is built),
/// PCL-free otherwise, so it also runs on the device machine. CSV into --out for
/// scripts/plot_benchmarks.py; a markdown summary per section on stdout. See docs/benchmarks.md.
///
/// Sections (--sections, default build,nn,knn,icp):
///   build  build time of every structure (CPU, best of the repeats) and its peak memory (the rise of
///          a forked child's peak RSS while it builds)
///   nn     exact 1-NN on ICP-like query sequences, queries in the order ICP issues them and shuffled
///          (one permutation for the whole run, so PNN hints still refer to one source point), over
///          --threads; every answer checked against the first tree peer
///   knn    kNN (--k) and radius (2.5 x the mean nearest-neighbour spacing): self-queries (every
///          reference point, at most --knn-queries of them, evenly strided) and foreign queries (the
///          converged ICP source)
///   icp    point-to-point ICP align() with each structure (one loop: same correspondences, so the same
///          poses), scan-to-scan with the build inside the timing and scan-to-model without; beside it
///          small_gicp's own ICP and GICP and stock PCL ICP, with their pose differences
// GCC 12 reports -Warray-bounds false positives inside Eigen's Umeyama at -march=native (the 16-byte
// load of a 12-byte vector is masked); see dw_bench.cpp. This must precede every include.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif

#include <malloc.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <sstream>

#include "common/point_files.h"
#include "common/query_replay.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"
#include "peers/peers.h"

namespace dwb {

std::vector<std::string> peerNames() {
  std::vector<std::string> n;
#ifdef DW_PEER_PICO_TREE
  n.push_back("pico_tree-" DW_PICO_TREE_LABEL);
#endif
#ifdef DW_PEER_NANOFLANN_NEW
  n.push_back("nanoflann-" DW_NANOFLANN_NEW_LABEL);
#endif
#ifdef DW_PEER_NANOFLANN_DEBIAN
  n.push_back("nanoflann-" DW_NANOFLANN_DEBIAN_LABEL);
#endif
#ifdef DW_PEER_SMALL_GICP
  n.push_back("small_gicp-" DW_SMALL_GICP_LABEL);
#endif
#ifdef DW_PEER_PCL
  n.push_back("pcl-kdtree-" DW_PCL_LABEL);
#endif
  return n;
}

std::vector<std::string> missingPeers() {
  std::vector<std::string> m;
#ifndef DW_PEER_PICO_TREE
  m.push_back("pico_tree (not found under DW_PEERS_DIR)");
#endif
#ifndef DW_PEER_NANOFLANN_NEW
  m.push_back("nanoflann 1.12 (not found under DW_PEERS_DIR)");
#endif
#ifndef DW_PEER_NANOFLANN_DEBIAN
  m.push_back("Debian's nanoflann (no nanoflann.hpp on the system path)");
#endif
#ifndef DW_PEER_SMALL_GICP
  m.push_back("small_gicp (not found under DW_PEERS_DIR)");
#endif
#ifndef DW_PEER_PCL
  m.push_back("PCL's KdTree (built without PCL)");
#endif
  return m;
}

std::unique_ptr<NnMethod> makePeer(const std::string& name) {
#ifdef DW_PEER_PICO_TREE
  if (name.rfind("pico_tree", 0) == 0) return makePicoTree();
#endif
#ifdef DW_PEER_NANOFLANN_NEW
  if (name == "nanoflann-" DW_NANOFLANN_NEW_LABEL) return makeNanoflannNew();
#endif
#ifdef DW_PEER_NANOFLANN_DEBIAN
  if (name == "nanoflann-" DW_NANOFLANN_DEBIAN_LABEL) return makeNanoflannDebian();
#endif
#ifdef DW_PEER_SMALL_GICP
  if (name.rfind("small_gicp", 0) == 0) return makeSmallGicpKdTree();
#endif
#ifdef DW_PEER_PCL
  if (name.rfind("pcl-kdtree", 0) == 0) return makePclKdTree();
#endif
  (void)name;
  return nullptr;
}

#ifndef DW_PEER_SMALL_GICP
PeerIcpResult smallGicpAlign(const std::vector<float>&, const std::vector<float>&, bool, double, int) {
  throw dw::Error("dw_peers: small_gicp is not built in");
}
#endif
#ifndef DW_PEER_PCL
PeerIcpResult pclStockIcp(const std::vector<float>&, const std::vector<float>&, double, int) {
  throw dw::Error("dw_peers: PCL is not built in");
}
#endif

}  // namespace dwb

namespace {

using dwb::Clock;

/// The walk variants measured: the default (PNN-optimized in ICP order), KD-ANN starts alone, and the
/// registration estimator's batch order (grouped by start vertex, prefetched).
const std::vector<std::string> kWalks = {"walk-pnn-optimized", "walk-kd-ann",
                                         "walk-pnn-optimized-sorted-prefetch"};

struct Options {
  std::string out = "bench/results/peers";
  std::vector<std::string> datasets{"dragon-100k", "kitti", "fastgicp", "autzen", "uniform-1M"};
  std::vector<std::string> methods;  // empty: the walks and every peer compiled in
  std::set<std::string> sections{"build", "nn", "knn", "icp"};
  std::vector<unsigned> threads{1};
  std::vector<std::size_t> ks{8, 16, 32};
  std::set<std::string> orders{"icp", "shuffled"};
  std::size_t iterations = 10, knn_queries = 100000, max_queries = 1000000;
  int repeats = 2;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

const char* kUsage =
    "usage: dw_peers [--sections build,nn,knn,icp] [--datasets a,b] [--methods a,b] [--threads 1,2,4]\n"
    "                [--iterations N] [--repeats N] [--k 8,16,32] [--knn-queries N] [--max-queries N]\n"
    "                [--orders icp,shuffled] [--out DIR]\n"
    "data sets: dragon-23k dragon-100k dragon-437k kitti fastgicp autzen uniform-1M scene-10M (generated)\n"
    "methods: walk-pnn-optimized walk-kd-ann walk-pnn-optimized-sorted-prefetch walk-pnn and the peers:\n";

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      for (const auto& p : dwb::peerNames()) std::cout << "  " << p << "\n";
      for (const auto& p : dwb::missingPeers()) std::cout << "  missing: " << p << "\n";
      std::exit(0);
    }
    if (a.rfind("--", 0) != 0 || i + 1 >= argc)
      throw dw::Error("dw_peers: bad argument '" + a + "' (see --help)");
    const std::string k = a.substr(2), v = argv[++i];
    auto num = [&](const std::string& s) {
      std::size_t used = 0;
      double x = 0;
      try {
        x = std::stod(s, &used);
      } catch (const std::exception&) {
      }
      if (used == 0 || used != s.size() || !(x >= 0))
        throw dw::Error("dw_peers: --" + k + " needs numbers, got '" + v + "'");
      return x;
    };
    if (k == "out") {
      o.out = v;
    } else if (k == "datasets") {
      o.datasets = split(v);
    } else if (k == "methods") {
      o.methods = split(v);
    } else if (k == "sections") {
      const auto s = split(v);
      o.sections = std::set<std::string>(s.begin(), s.end());
      for (const auto& x : o.sections)
        if (x != "build" && x != "nn" && x != "knn" && x != "icp")
          throw dw::Error("dw_peers: unknown section '" + x + "'");
    } else if (k == "threads") {
      o.threads.clear();
      for (const auto& s : split(v)) o.threads.push_back(unsigned(num(s)));
      for (unsigned t : o.threads)
        if (t < 1 || t > 256) throw dw::Error("dw_peers: thread counts must be in 1..256");
    } else if (k == "orders") {
      const auto s = split(v);
      o.orders = std::set<std::string>(s.begin(), s.end());
      for (const auto& x : o.orders)
        if (x != "icp" && x != "shuffled") throw dw::Error("dw_peers: unknown query order '" + x + "'");
    } else if (k == "k") {
      o.ks.clear();
      for (const auto& s : split(v)) o.ks.push_back(std::size_t(num(s)));
    } else if (k == "iterations") {
      o.iterations = std::size_t(num(v));
    } else if (k == "repeats") {
      o.repeats = int(num(v));
    } else if (k == "knn-queries") {
      o.knn_queries = std::size_t(num(v));
    } else if (k == "max-queries") {
      o.max_queries = std::size_t(num(v));
    } else {
      throw dw::Error("dw_peers: unknown option --" + k + " (see --help)");
    }
  }
  if (o.iterations < 1 || o.repeats < 1 || o.knn_queries < 1 || o.max_queries < 1)
    throw dw::Error("dw_peers: iteration, repeat and query counts must be >= 1");
  if (o.methods.empty()) {
    o.methods = kWalks;
    for (const auto& p : dwb::peerNames()) o.methods.push_back(p);
  }
  return o;
}

std::unique_ptr<dwb::NnMethod> make(const std::string& name) {
  if (name.rfind("walk-", 0) == 0) return dwb::makeWalk(name);
  auto m = dwb::makePeer(name);
  if (!m) throw dw::Error("dw_peers: method '" + name + "' is not compiled in (see --help)");
  return m;
}

/// A CSV file with a header, flushed per row.
class Csv {
 public:
  Csv(const std::string& path, const std::string& header) : f_(path) {
    if (!f_) throw dw::Error("dw_peers: cannot write '" + path + "'");
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

/// One comparison's data: the reference (target) and the ICP-like source. Pairs of real frames give
/// the next frame as the source; the others are their own target rotated as in the seed's protocol.
struct Scene {
  std::string name, source_file;
  std::vector<float> target, source;
  double max_dist = 1e300;  ///< ICP's correspondence cut-off (metres for LiDAR)
  std::size_t size() const { return target.size() / 3; }
};

/// Finite points, recentred on the bounding-box centre in double before rounding to float (the
/// airborne tiles' UTM coordinates would lose centimetres in float); every method gets these floats.
std::vector<float> toFloat(const std::vector<double>& xyz, const double* centre, bool drop_origin) {
  std::vector<float> out;
  out.reserve(xyz.size());
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) {
    if (!std::isfinite(xyz[i]) || !std::isfinite(xyz[i + 1]) || !std::isfinite(xyz[i + 2])) continue;
    // LiDAR no-return points sit at exactly (0, 0, 0): they would match each other at distance 0.
    if (drop_origin && xyz[i] == 0 && xyz[i + 1] == 0 && xyz[i + 2] == 0) continue;
    for (int a = 0; a < 3; ++a) out.push_back(static_cast<float>(xyz[i + a] - centre[a]));
  }
  return out;
}

std::vector<float> loadRecentred(const std::string& path, bool drop_origin,
                                 const double* use_centre = nullptr, double* centre_out = nullptr) {
  const std::vector<double> xyz = dwb::readAnyXyz(path);
  double c[3] = {0, 0, 0};
  if (use_centre) {
    std::copy(use_centre, use_centre + 3, c);
  } else if (!xyz.empty()) {
    double lo[3] = {xyz[0], xyz[1], xyz[2]}, hi[3] = {xyz[0], xyz[1], xyz[2]};
    for (std::size_t i = 0; i + 2 < xyz.size(); i += 3)
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], xyz[i + a]), hi[a] = std::max(hi[a], xyz[i + a]);
    for (int a = 0; a < 3; ++a) c[a] = std::floor(0.5 * (lo[a] + hi[a]));
  }
  if (centre_out) std::copy(c, c + 3, centre_out);
  return toFloat(xyz, c, drop_origin);
}

Scene loadScene(const std::string& name) {
  Scene s;
  s.name = name;
  const dwb::Rotation model_rotation{10, 10, 10};
  auto rotatedSelf = [&](const dwb::Rotation& r) {
    s.source = dwb::transformed(s.target, r.about(dwb::centroid(s.target)));
  };
  auto pair = [&](const char* target, const char* source, double max_dist) {
    double c[3];
    s.source_file = dwb::findDataFile("scans", target);
    s.target = loadRecentred(s.source_file, true, nullptr, c);
    s.source = loadRecentred(dwb::findDataFile("scans", source), true, c);
    s.max_dist = max_dist;
  };
  if (name == "dragon-23k" || name == "dragon-100k" || name == "dragon-437k") {
    const char* file = name == "dragon-23k"    ? "dragon_vrip_res3.ply"
                       : name == "dragon-100k" ? "dragon_vrip_res2.ply.gz"
                                               : "dragon_vrip.ply.gz";
    s.source_file = dwb::findDataFile("models", file);
    if (s.source_file.size() > 3 && s.source_file.compare(s.source_file.size() - 3, 3, ".gz") == 0)
      s.source_file = dwb::gunzipToCache(s.source_file);
    s.target = loadRecentred(s.source_file, false);
    rotatedSelf(model_rotation);
  } else if (name == "kitti") {
    pair("kitti_000000.bin", "kitti_000001.bin", 1.0);  // the next frame as the queries
  } else if (name == "fastgicp") {
    pair("fastgicp_251370668.pcd", "fastgicp_251371071.pcd", 1.0);
  } else if (name == "autzen") {
    // The airborne tile in its file (flight-line) order, moved as a small ICP-like misregistration.
    s.source_file = dwb::findDataFile("airborne", "autzen_trim.las");
    s.target = loadRecentred(s.source_file, false);
    rotatedSelf(dwb::Rotation{1, 1, 3});
  } else if (name == "uniform-1M") {
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    s.target.resize(3 * 1000000);
    for (float& v : s.target) v = u(rng);
    s.source_file = "generated: 1M uniform points in the unit cube, seed 42";
    rotatedSelf(model_rotation);
  } else if (name == "scene-10M") {
    // Synthetic airborne LiDAR (terrain, buildings, trees), 10M returns in acquisition order.
    dw::las::LidarGenOptions g;
    g.num_points = 10000000;
    const dw::las::LasHeader h = dw::las::syntheticHeader(g);
    std::vector<double> xyz;
    xyz.reserve(3 * g.num_points);
    dw::las::generateLidar(g, [&](const dw::las::LasRecord& r) {
      xyz.insert(xyz.end(), {r.X * h.scale[0] + h.offset[0], r.Y * h.scale[1] + h.offset[1],
                             r.Z * h.scale[2] + h.offset[2]});
    });
    const double c[3] = {g.offset_x, g.offset_y, 0.0};
    s.target = toFloat(xyz, c, false);
    s.source_file = "generated: dw::las::generateLidar, 10M returns, seed 1";
    rotatedSelf(dwb::Rotation{1, 1, 3});
  } else {
    throw dw::Error("dw_peers: unknown data set '" + name + "' (see --help)");
  }
  if (s.target.empty()) throw dw::Error("dw_peers: data set '" + name + "' has no finite points");
  return s;
}

/// Every m-th point, m chosen so that at most `max` remain (the order kept).
std::vector<float> strided(const std::vector<float>& xyz, std::size_t max) {
  const std::size_t n = xyz.size() / 3, m = (n + max - 1) / max;
  if (m <= 1) return xyz;
  std::vector<float> out;
  for (std::size_t i = 0; i < n; i += m) out.insert(out.end(), &xyz[3 * i], &xyz[3 * i] + 3);
  return out;
}

double bestOf(int repeats, const std::function<void()>& f, double* cpu_out = nullptr) {
  double best = 1e300, best_cpu = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = Clock::now();
    const double c0 = dwb::processCpuSeconds();
    f();
    best_cpu = std::min(best_cpu, dwb::processCpuSeconds() - c0);
    best = std::min(best, dwb::secondsSince(t0));
  }
  if (cpu_out) *cpu_out = best_cpu;
  return best;
}

/// Rise of the peak resident set while `build` runs, measured in a forked child (so that the parent's
/// heap and the earlier builds do not count): the child resets its peak (clear_refs 5), builds, and
/// reports VmHWM minus its resident size before the build (free heap trimmed first). -1 where the
/// kernel cannot tell.
long long peakBuildBytes(const std::function<void()>& build) {
  int fd[2];
  if (::pipe(fd) != 0) return -1;
  std::cout.flush();
  const pid_t pid = ::fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    auto status = [](const char* key) {
      std::ifstream f("/proc/self/status");
      std::string line;
      while (std::getline(f, line))
        if (line.rfind(key, 0) == 0) return std::atoll(line.c_str() + std::strlen(key)) * 1024LL;
      return -1LL;
    };
    long long v = -1;
    // Free heap pages inherited from the parent would be reused without raising the resident size:
    // hand them back first, so that every page the build touches counts.
    ::malloc_trim(0);
    {
      std::ofstream clear("/proc/self/clear_refs");
      clear << "5";
    }
    const long long before = status("VmRSS:");
    if (before >= 0 && status("VmHWM:") <= before + (1 << 20)) {
      build();
      v = status("VmHWM:") - before;
    }
    if (::write(fd[1], &v, sizeof v) != sizeof v) ::_exit(1);
    ::_exit(0);
  }
  ::close(fd[1]);
  long long v = -1;
  if (::read(fd[0], &v, sizeof v) != sizeof v) v = -1;
  ::close(fd[0]);
  int st = 0;
  ::waitpid(pid, &st, 0);
  return v;
}

std::string versionOf(const dwb::NnMethod& m) {
  return m.version().empty() ? "this tree" : m.version();
}

/// A markdown table of ns/query per method (rows) and column label, with each row's ratio to the
/// fastest peer (non-walk) of the column: what the device script prints.
void printTable(const std::string& title, const std::vector<std::string>& cols,
                const std::map<std::string, std::map<std::string, double>>& ns) {
  std::cout << "\n" << title << "\n\n| method |";
  for (const auto& c : cols) std::cout << " " << c << " |";
  std::cout << "\n|---|";
  for (std::size_t i = 0; i < cols.size(); ++i) std::cout << "---|";
  std::cout << "\n";
  std::map<std::string, double> best_peer;
  for (const auto& [m, row] : ns)
    if (m.rfind("walk-", 0) != 0)
      for (const auto& [c, v] : row)
        if (!best_peer.count(c) || v < best_peer[c]) best_peer[c] = v;
  for (const auto& [m, row] : ns) {
    std::cout << "| " << m << " |";
    for (const auto& c : cols) {
      auto it = row.find(c);
      if (it == row.end()) {
        std::cout << " – |";
        continue;
      }
      char buf[64];
      if (best_peer.count(c))
        std::snprintf(buf, sizeof buf, " %.0f (%.2fx) |", it->second, best_peer[c] / it->second);
      else
        std::snprintf(buf, sizeof buf, " %.0f |", it->second);
      std::cout << buf;
    }
    std::cout << "\n";
  }
  std::cout << "\n(ns per query; in brackets: the fastest peer's time / this method's, > 1 = faster than "
               "every peer)\n";
}

/// The methods of one scene, built once (the walks share one graph).
struct Built {
  std::vector<std::pair<std::string, std::shared_ptr<dwb::NnMethod>>> methods;
  std::shared_ptr<dwb::NnMethod> reference;  ///< the first tree peer: the answers' check
};

Built buildAll(const Options& o, const Scene& s) {
  Built b;
  std::shared_ptr<dwb::WalkNn> first_walk;
  for (const auto& name : o.methods) {
    std::shared_ptr<dwb::NnMethod> m = make(name);
    auto walk = std::dynamic_pointer_cast<dwb::WalkNn>(m);
    if (walk && first_walk)
      walk->shareGraph(*first_walk);
    else
      m->build(s.target);
    if (walk && !first_walk) first_walk = walk;
    if (!walk && !b.reference) b.reference = m;
    b.methods.emplace_back(name, m);
  }
  if (!b.reference) {
    b.reference = first_walk;  // walks only: they are checked against each other
    std::cout << "  (no tree peer: the walks' answers are compared with each other only)\n";
  }
  return b;
}

void sectionBuild(const Options& o, const Scene& s, Csv& csv) {
  std::vector<std::string> names;
  bool walk_done = false;
  for (const auto& n : o.methods) {
    if (n.rfind("walk-", 0) == 0) {
      if (walk_done) continue;  // every walk stands on one graph
      walk_done = true;
    }
    names.push_back(n);
  }
  std::cout << "  build (CPU s, best of " << o.repeats << "; peak = rise of peak RSS while building):\n";
  for (const auto& n : names) {
    double cpu = 0;
    std::size_t held = 0;
    bestOf(
        o.repeats,
        [&] {
          auto m = make(n);
          m->build(s.target);
          held = m->memoryBytes();
        },
        &cpu);
    const long long peak = peakBuildBytes([&] {
      auto m = make(n);
      m->build(s.target);
    });
    const std::string label = n.rfind("walk-", 0) == 0 ? "walk-graph" : n;
    csv.row(s.name, s.size(), label, versionOf(*make(n)), cpu, peak, held);
    std::printf("    %-34s %9.1f ms  peak %7.1f B/pt  held %7.1f B/pt\n", label.c_str(), cpu * 1e3,
                peak >= 0 ? double(peak) / double(s.size()) : -1.0, double(held) / double(s.size()));
  }
}

void sectionNn(const Options& o, const Scene& s, const Built& b, Csv& csv) {
  const std::vector<float> source = strided(s.source, o.max_queries);
  const dwb::IcpSequence seq = dwb::makeIcpSequence(source, s.target, *b.reference, o.iterations, s.max_dist);
  // Shuffled: one permutation of the source points for the whole run.
  dwb::IcpSequence shuffled = seq;
  {
    const std::size_t n = source.size() / 3;
    std::vector<std::size_t> perm(n);
    std::iota(perm.begin(), perm.end(), 0);
    std::shuffle(perm.begin(), perm.end(), std::mt19937_64(7));
    for (std::size_t i = 0; i < n; ++i)
      std::copy(&source[3 * perm[i]], &source[3 * perm[i]] + 3, &shuffled.source[3 * i]);
  }
  std::cout << "  nn: " << seq.poses.size() << " ICP iterations x " << source.size() / 3 << " queries\n";
  std::map<std::string, std::map<std::string, double>> table;
  std::vector<std::string> cols;
  for (const auto& [order, sq] :
       {std::pair<std::string, const dwb::IcpSequence*>{"icp", &seq}, {"shuffled", &shuffled}}) {
    if (!o.orders.count(order)) continue;
    const dwb::QueryReplay replay(*sq);
    dwb::NnBatch batch;
    std::vector<std::vector<int>> want, got;
    replay.run(*b.reference, batch, 1, nullptr, &want);
    for (unsigned t : o.threads) cols.push_back(order + " x" + std::to_string(t));
    for (const auto& [name, m] : b.methods) {
      std::vector<std::uint32_t> steps;
      replay.run(*m, batch, 1, &steps, &got);
      std::size_t wrong = 0;
      for (std::size_t it = 0; it < got.size(); ++it)
        wrong +=
            dwb::countWrong(s.target, replay.iterations[it].data(), replay.per_iteration, got[it], want[it]);
      double mean_steps = -1;
      if (m->isWalk() && !steps.empty())
        mean_steps = std::accumulate(steps.begin(), steps.end(), 0.0) / double(steps.size());
      for (unsigned t : o.threads) {
        double cpu = 0;
        const double wall = bestOf(
            o.repeats, [&] { replay.run(*m, batch, t); }, &cpu);
        const double q = double(replay.numQueries());
        // One thread: CPU time (steady on a shared machine); more: wall clock.
        const double ns = (t == 1 ? cpu : wall) * 1e9 / q;
        csv.row(s.name, s.size(), order, name, versionOf(*m), t, replay.numQueries(),
                replay.iterations.size(), wall * 1e9 / q, cpu * 1e9 / q, mean_steps, wrong);
        table[name][order + " x" + std::to_string(t)] = ns;
        std::printf("    %-8s %-36s x%-2u %8.1f ns/query  wrong %zu%s\n", order.c_str(), name.c_str(), t, ns,
                    wrong, mean_steps >= 0 ? ("  mean walk " + std::to_string(mean_steps)).c_str() : "");
      }
    }
  }
  printTable("exact 1-NN, " + s.name + " (" + std::to_string(s.size()) + " points), ICP-like sequence", cols,
             table);
}

/// Mean distance from a point to its nearest other point, from self-kNN answers with k >= 2.
double meanSpacing(const dwb::KnnBatch& b) {
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < b.count.size(); ++i)
    if (b.count[i] >= 2) sum += std::sqrt(double(b.dist2[i * b.k + 1])), ++n;
  return n ? sum / double(n) : 0.0;
}

void sectionKnn(const Options& o, const Scene& s, const Built& b, Csv& csv) {
  // Self-queries: every m-th reference point, at most knn_queries of them.
  const std::size_t n = s.size(), m = std::max<std::size_t>(1, (n + o.knn_queries - 1) / o.knn_queries);
  std::vector<float> self_q;
  for (std::size_t i = 0; i < n; i += m) self_q.insert(self_q.end(), &s.target[3 * i], &s.target[3 * i] + 3);

  const std::vector<float> foreign = strided(s.source, o.knn_queries);
  dwb::KnnBatch ref, got;
  b.reference->knn(self_q.data(), self_q.size() / 3, 8, ref, 1, m);
  const double spacing = meanSpacing(ref);
  const float r2 = float(std::pow(2.5 * spacing, 2));
  std::cout << "  knn: " << self_q.size() / 3 << " self-queries, " << foreign.size() / 3
            << " foreign; mean spacing " << spacing << ", radius " << 2.5 * spacing << "\n";
  struct Job {
    std::string query, kind;
    std::size_t k;
  };
  std::vector<Job> jobs;
  for (std::size_t k : o.ks) jobs.push_back({"self", "knn", k});
  jobs.push_back({"self", "radius", 0});
  jobs.push_back({"foreign", "knn", 16});
  jobs.push_back({"foreign", "radius", 0});
  std::map<std::string, std::map<std::string, double>> table;
  std::vector<std::string> cols;
  for (const Job& j : jobs) {
    const std::vector<float>& q = j.query == "self" ? self_q : foreign;
    const std::size_t nq = q.size() / 3;
    const std::size_t self = j.query == "self" ? m : 0;  // query i is reference point i * m
    auto run = [&](dwb::NnMethod& mm, dwb::KnnBatch& out, unsigned t) {
      if (j.kind == "knn")
        mm.knn(q.data(), nq, j.k, out, t, self);
      else
        mm.radius(q.data(), nq, r2, out, t, self);
    };
    run(*b.reference, ref, 1);
    const std::string col = j.query + (j.kind == "knn" ? " k=" + std::to_string(j.k) : " radius");
    cols.push_back(col);
    for (const auto& [name, mm] : b.methods) {
      if (!mm->hasKnn()) continue;
      try {
        run(*mm, got, 1);
      } catch (const dw::Error& e) {
        std::cout << "    " << name << ": " << e.what() << "\n";
        continue;
      }
      // Differences: a kNN whose k-th distance is off, a radius count that differs (points on the
      // sphere within float rounding may fall either side).
      std::size_t differ = 0;
      double found = 0;
      for (std::size_t i = 0; i < nq; ++i) {
        found += got.count[i];
        const float a = got.far2[i], r = ref.far2[i];
        if (got.count[i] != ref.count[i] && (j.kind == "knn" || std::fabs(a - r) > 1e-5f * (r + 1e-12f)))
          ++differ;
        else if (j.kind == "knn" && std::fabs(a - r) > 1e-4f * r + 1e-12f)
          ++differ;
      }
      for (unsigned t : o.threads) {
        double cpu = 0;
        const double wall = bestOf(
            o.repeats, [&] { run(*mm, got, t); }, &cpu);
        const double ns = (t == 1 ? cpu : wall) * 1e9 / double(nq);
        csv.row(s.name, s.size(), j.query, j.kind, j.k, std::sqrt(r2), name, versionOf(*mm), t, nq,
                wall * 1e9 / double(nq), cpu * 1e9 / double(nq), found / double(nq), differ);
        if (t == o.threads.front()) table[name][col] = ns;
        std::printf("    %-20s %-36s x%-2u %9.1f ns/query  mean found %.1f  differ %zu\n", col.c_str(),
                    name.c_str(), t, ns, found / double(nq), differ);
      }
    }
  }
  printTable("kNN and radius, " + s.name + " (" + std::to_string(s.size()) + " points), " +
                 std::to_string(o.threads.front()) + " thread(s)",
             cols, table);
}

void poseDiff(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double& deg, double& trans) {
  dwb::poseError(a, b, deg, trans);
}

void sectionIcp(const Options& o, const Scene& s, Csv& csv) {
  const int max_it = 100;
  // Scan-to-scan for real pairs (a new target each frame: the build is inside the time); scan-to-model
  // (the target's structure reused) for every scene.
  const bool pair = s.max_dist < 1e299;
  std::cout << "  icp: " << s.source.size() / 3 << " -> " << s.size()
            << " points, max correspondence distance "
            << (pair ? std::to_string(s.max_dist) : std::string("none")) << ", at most " << max_it
            << " iterations\n";
  Eigen::Matrix4d walk_pose = Eigen::Matrix4d::Identity();
  bool have_walk_pose = false;
  std::vector<std::string> names;
  for (const auto& n : o.methods)
    if (n != "walk-kd-ann") names.push_back(n);
  for (const auto& name : names) {
    double best = 1e300, best_build = 0, nn = 0, solve = 0;
    dwb::IcpResult r;
    for (int rep = 0; rep < o.repeats; ++rep) {
      auto m = make(name);
      const double c0 = dwb::processCpuSeconds();
      m->build(s.target);
      const double build = dwb::processCpuSeconds() - c0;
      const dwb::IcpResult run = dwb::pointToPointIcp(s.source, s.target, *m, max_it, s.max_dist);
      const double total = dwb::processCpuSeconds() - c0;
      if (total < best)
        best = total, best_build = build, r = run, nn = run.nn_seconds, solve = run.solve_seconds;
    }
    if (!have_walk_pose) walk_pose = r.pose, have_walk_pose = true;
    double deg = 0, trans = 0;
    poseDiff(walk_pose, r.pose, deg, trans);
    const std::string m_version = versionOf(*make(name));
    csv.row(s.name, s.size(), s.source.size() / 3, name, m_version, r.poses.size(), r.converged ? 1 : 0, best,
            best_build, best - best_build, nn, solve, deg, trans);
    std::printf(
        "    %-36s %3zu it  scan-to-scan %8.1f ms  scan-to-model %8.1f ms (nn %.1f, rest %.1f)  vs first: "
        "%.2g deg %.2g\n",
        name.c_str(), r.poses.size(), best * 1e3, (best - best_build) * 1e3, nn * 1e3, solve * 1e3, deg,
        trans);
  }
  struct Own {
    const char* name;
    std::function<dwb::PeerIcpResult()> run;
  };
  std::vector<Own> own;
  [[maybe_unused]] const double md = s.max_dist < 1e299 ? s.max_dist : 1e10;
#ifdef DW_PEER_SMALL_GICP
  own.push_back(
      {"small_gicp-icp", [&] { return dwb::smallGicpAlign(s.source, s.target, false, md, max_it); }});
  own.push_back(
      {"small_gicp-gicp", [&] { return dwb::smallGicpAlign(s.source, s.target, true, md, max_it); }});
#endif
#ifdef DW_PEER_PCL
  own.push_back({"pcl-icp-stock", [&] { return dwb::pclStockIcp(s.source, s.target, s.max_dist, max_it); }});
#endif
  for (const Own& w : own) {
    dwb::PeerIcpResult best;
    best.seconds = 1e300;
    for (int rep = 0; rep < o.repeats; ++rep) {
      const dwb::PeerIcpResult r = w.run();
      if (r.seconds < best.seconds) best = r;
    }
    double deg = 0, trans = 0;
    poseDiff(walk_pose, best.pose, deg, trans);
    csv.row(s.name, s.size(), s.source.size() / 3, w.name, "own registration", best.iterations,
            best.converged ? 1 : 0, best.seconds, best.prep_seconds, best.seconds - best.prep_seconds, -1, -1,
            deg, trans);
    std::printf("    %-36s %3d it  whole %8.1f ms (trees/covariances %.1f)  vs first: %.3g deg %.3g\n",
                w.name, best.iterations, best.seconds * 1e3, best.prep_seconds * 1e3, deg, trans);
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
    std::cout << std::unitbuf;
    std::setvbuf(stdout, nullptr, _IOLBF, 0);  // the printf progress lines too, when logged to a file
    const Options o = parse(argc, argv);
    if (std::system(("mkdir -p '" + o.out + "'").c_str()) != 0)
      throw dw::Error("dw_peers: cannot create " + o.out);
    {
      Csv meta(o.out + "/meta.csv", "key,value");
      meta.row("cpu", "\"" + cpuModel() + "\"");
      meta.row("hardware_threads", std::thread::hardware_concurrency());
      meta.row("compiler", std::string("\"") + __VERSION__ + "\"");
      for (const auto& p : dwb::peerNames()) meta.row("peer", p);
      for (const auto& p : dwb::missingPeers()) meta.row("missing", "\"" + p + "\"");
    }
    std::cout << "dw_peers on " << cpuModel() << " (" << std::thread::hardware_concurrency()
              << " threads)\npeers:";
    for (const auto& p : dwb::peerNames()) std::cout << " " << p;
    std::cout << "\n";
    for (const auto& p : dwb::missingPeers()) std::cout << "skipped: " << p << "\n";
    std::unique_ptr<Csv> build_csv, nn_csv, knn_csv, icp_csv;
    if (o.sections.count("build"))
      build_csv = std::make_unique<Csv>(o.out + "/build.csv",
                                        "dataset,points,method,version,cpu_seconds,peak_bytes,held_bytes");
    if (o.sections.count("nn"))
      nn_csv = std::make_unique<Csv>(o.out + "/nn.csv",
                                     "dataset,points,order,method,version,threads,queries,icp_iterations,"
                                     "ns_per_query,cpu_ns_per_query,mean_steps,wrong");
    if (o.sections.count("knn"))
      knn_csv = std::make_unique<Csv>(o.out + "/knn.csv",
                                      "dataset,points,query,kind,k,radius,method,version,threads,queries,"
                                      "ns_per_query,cpu_ns_per_query,mean_found,differ");
    if (o.sections.count("icp"))
      icp_csv =
          std::make_unique<Csv>(o.out + "/icp.csv",
                                "dataset,points,source_points,method,version,iterations,converged,"
                                "scan2scan_cpu_seconds,build_cpu_seconds,scan2model_cpu_seconds,nn_seconds,"
                                "solve_seconds,rot_diff_deg,trans_diff");
    for (const auto& name : o.datasets) {
      const Scene s = loadScene(name);
      std::cout << "== " << s.name << ": " << s.size() << " points, " << s.source.size() / 3 << " queries ("
                << s.source_file << ")\n";
      if (build_csv) sectionBuild(o, s, *build_csv);
      if (nn_csv || knn_csv) {
        const Built b = buildAll(o, s);
        if (nn_csv) sectionNn(o, s, b, *nn_csv);
        if (knn_csv) sectionKnn(o, s, b, *knn_csv);
      }
      if (icp_csv) sectionIcp(o, s, *icp_csv);
    }
    std::cout << "results in " << o.out << "/\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "dw_peers: error: " << e.what() << "\n";
    return 1;
  }
}
