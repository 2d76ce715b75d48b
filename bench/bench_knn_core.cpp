// Google Benchmark: exact self-kNN and self-radius search, the walk's expansion beside the k-d tree
// peers in one process, one thread. Every reference point asks for its own k nearest (k = 8, 16,
// 32) or for every point within a radius of 2.5 x the cloud's median nearest-neighbour spacing, in
// input order (what NormalEstimation, GICP's covariances and clustering ask):
//
//   kNN/<data>/k:<k>/<method>        ns_per_query
//   Radius/<data>/<method>           ns_per_query, mean_results
//
// Methods: walk-core (dw::NeighbourSearch, the expansion started at the point's own vertex),
// walk-caller (dw::CallerMetricSearch: what pcl::search::DelaunayWalk::nearestKSearch(index, ...)
// runs, FLANN's float metric and tie rule), and the peers where they were found at configure time
// (DW_PEERS_DIR): nanoflann 1.12.1 (leaf 10, L2_Simple) and pico_tree (leaf 10). Each method's answers are
// checked against nanoflann's (or, without it, walk-core's): the counter `mismatches` counts queries whose
// sorted distances differ beyond float rounding, and must be 0. After the runs a table prints each peer's
// time over the walk's (ratio > 1: the walk is faster).
//
// Data sets: $DW_BENCH_DATASETS (comma list, default kitti,dragon-23k): kitti is
// scans/kitti_000000.bin under $DW_DATA_DIR (the shared data folder), dragon-23k the bundled
// data/dragon_vrip_res3.ply. The core only: builds and runs without PCL (the device machine).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#ifdef DW_HAVE_PEER_NANOFLANN
#include <nanoflann.hpp>
#endif
#ifdef DW_HAVE_PEER_PICO_TREE
#include <pico_tree/array_traits.hpp>
#include <pico_tree/kd_tree.hpp>
#include <pico_tree/vector_traits.hpp>
#endif

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/search/caller_metric_search.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace {

constexpr double kRadiusFactor = 2.5;

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

bool readable(const std::string& p) {
  return std::ifstream(p).good();
}

std::string findFile(const std::string& name) {
  std::vector<std::string> cands;
  std::string rel;
  if (name == "kitti") {
    rel = "scans/kitti_000000.bin";
  } else if (name == "dragon-23k") {
    rel = "models/dragon_vrip_res3.ply";
    cands.push_back(std::string(DW_TEST_DATA_DIR) + "/dragon_vrip_res3.ply");
  } else {
    throw dw::Error("bench_knn_core: unknown data set '" + name + "' (known: kitti, dragon-23k)");
  }
  if (const char* env = std::getenv("DW_DATA_DIR")) cands.insert(cands.begin(), std::string(env) + "/" + rel);
  cands.push_back(std::string(DW_SHARED_DATA_DIR) + "/" + rel);
  for (const auto& c : cands)
    if (readable(c)) return c;
  std::string msg = "bench_knn_core: no file for data set '" + name + "'; looked in:";
  for (const auto& c : cands) msg += " " + c;
  throw dw::Error(msg + " (set DW_DATA_DIR to the shared data folder)");
}

/// One reference cloud with every structure built once.
struct Fixture {
  std::string name;
  std::vector<float> xyz;  ///< finite points only, 3 floats each
  std::size_t size() const { return xyz.size() / 3; }
  dw::DelaunayGraph::ConstPtr graph;
  std::unique_ptr<dw::NeighbourSearch> search;
  std::unique_ptr<dw::CallerMetricSearch> caller;
  double radius = 0;  ///< kRadiusFactor x the median nearest-neighbour distance
};

std::map<std::string, std::shared_ptr<Fixture>>& fixtures() {
  static std::map<std::string, std::shared_ptr<Fixture>> f;
  return f;
}

std::shared_ptr<Fixture> load(const std::string& name) {
  auto f = std::make_shared<Fixture>();
  f->name = name;
  const std::string path = findFile(name);
  const std::vector<double> raw = dw::readPointsXyz(path);
  for (std::size_t i = 0; i + 2 < raw.size(); i += 3)
    if (std::isfinite(raw[i]) && std::isfinite(raw[i + 1]) && std::isfinite(raw[i + 2]))
      f->xyz.insert(f->xyz.end(), {float(raw[i]), float(raw[i + 1]), float(raw[i + 2])});
  std::fprintf(stderr, "bench_knn_core: %s: %zu points from %s; building the graph...\n", name.c_str(),
               f->size(), path.c_str());
  dw::BuildOptions opt;
  opt.num_threads = 1;
  f->graph = std::make_shared<dw::DelaunayGraph>(
      dw::buildDelaunayGraph(dw::PointView::fromFloat(f->xyz.data(), f->size()), opt));
  f->search = std::make_unique<dw::NeighbourSearch>(f->graph);
  f->caller = std::make_unique<dw::CallerMetricSearch>(f->graph, f->xyz, std::vector<std::int32_t>{});
  // A vertex's nearest other vertex is its shortest edge (the first record): 2 m.
  const dw::DelaunayGraph& g = *f->graph;
  std::vector<float> nn;
  for (std::size_t v = 0; v < g.numVertices(); ++v)
    if (g.degree(dw::index_t(v)) > 0) nn.push_back(2.f * g.edges[g.offsets[v]].m);
  std::nth_element(nn.begin(), nn.begin() + nn.size() / 2, nn.end());
  f->radius = kRadiusFactor * (nn.empty() ? 1.0 : nn[nn.size() / 2]);
  return f;
}

/// A method answers every reference point's self query into sorted squared distances.
struct SelfQueries {
  virtual ~SelfQueries() = default;
  /// k nearest of point i (k > 0) or, for k == 0, every point within the fixture's radius.
  virtual void query(std::size_t i, std::size_t k, std::vector<float>& d2) = 0;
  /// The whole pass; methods with a batch API override it.
  virtual void all(std::size_t k, std::vector<float>& sink) {
    std::vector<float> d2;
    for (std::size_t i = 0; i < n_; ++i) {
      query(i, k, d2);
      sink[i] = d2.empty() ? 0.f : d2.back();
    }
  }
  std::size_t n_ = 0;
};

struct WalkCore : SelfQueries {
  explicit WalkCore(const Fixture& f) : f_(f) { n_ = f.size(); }
  void query(std::size_t i, std::size_t k, std::vector<float>& d2) override {
    const dw::DelaunayGraph& g = *f_.graph;
    const dw::index_t v = g.input_to_vertex[i];
    const dw::WalkResult nn{v, 0.f, 0};
    if (k > 0)
      f_.search->knn(g.points[v], k, nn, idx_, d2);
    else
      f_.search->radius(g.points[v], float(f_.radius * f_.radius), nn, idx_, d2);
  }
  const Fixture& f_;
  std::vector<dw::index_t> idx_;
};

struct WalkCaller : SelfQueries {
  explicit WalkCaller(const Fixture& f) : f_(f) { n_ = f.size(); }
  void query(std::size_t i, std::size_t k, std::vector<float>& d2) override {
    const float* q = &f_.xyz[3 * i];
    const dw::index_t v = f_.caller->vertexOfInput(i);
    if (k > 0)
      f_.caller->knn(q, k, dw::StartStrategy::Pnn, v, out_);
    else
      f_.caller->radius(q, f_.radius, 0, dw::StartStrategy::Pnn, v, out_);
    d2.resize(out_.size());
    for (std::size_t j = 0; j < out_.size(); ++j) d2[j] = out_[j].sqr_distance;
  }
  const Fixture& f_;
  std::vector<dw::WalkNeighbour> out_;
};

#ifdef DW_HAVE_PEER_NANOFLANN
struct NanoflannPeer : SelfQueries {
  struct Adaptor {
    const std::vector<float>* xyz;
    std::size_t kdtree_get_point_count() const { return xyz->size() / 3; }
    float kdtree_get_pt(std::size_t i, std::size_t d) const { return (*xyz)[3 * i + d]; }
    template <class B>
    bool kdtree_get_bbox(B&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Adaptor>, Adaptor, 3,
                                                   std::uint32_t>;
  explicit NanoflannPeer(const Fixture& f)
      : f_(f), adaptor_{&f.xyz}, tree_(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {
    n_ = f.size();
  }
  void query(std::size_t i, std::size_t k, std::vector<float>& d2) override {
    const float* q = &f_.xyz[3 * i];
    if (k > 0) {
      idx_.resize(k);
      d2.resize(k);
      d2.resize(tree_.knnSearch(q, k, idx_.data(), d2.data()));
    } else {
      const std::size_t found =
          tree_.radiusSearch(q, float(f_.radius * f_.radius), items_, nanoflann::SearchParameters(0.f, true));
      d2.resize(found);
      for (std::size_t j = 0; j < found; ++j) d2[j] = items_[j].second;
    }
  }
  const Fixture& f_;
  Adaptor adaptor_;
  Tree tree_;
  std::vector<std::uint32_t> idx_;
  std::vector<nanoflann::ResultItem<std::uint32_t, float>> items_;
};
#endif

#ifdef DW_HAVE_PEER_PICO_TREE
struct PicoTreePeer : SelfQueries {
  using Points = std::vector<std::array<float, 3>>;
  using Tree = pico_tree::kd_tree<std::reference_wrapper<Points>>;
  static Points copy(const std::vector<float>& xyz) {
    Points p(xyz.size() / 3);
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
    return p;
  }
  explicit PicoTreePeer(const Fixture& f)
      : f_(f), points_(copy(f.xyz)), tree_(std::ref(points_), pico_tree::max_leaf_size_t(10)) {
    n_ = f.size();
  }
  void query(std::size_t i, std::size_t k, std::vector<float>& d2) override {
    if (k > 0)
      tree_.search_knn(points_[i], k, nb_);
    else
      tree_.search_radius(points_[i], float(f_.radius * f_.radius), nb_, true);
    d2.resize(nb_.size());
    for (std::size_t j = 0; j < nb_.size(); ++j) d2[j] = nb_[j].distance;
  }
  const Fixture& f_;
  Points points_;
  Tree tree_;
  std::vector<pico_tree::neighbor<int, float>> nb_;
};
#endif

std::vector<std::string> methodNames() {
  std::vector<std::string> m = {"walk-core", "walk-caller"};
#ifdef DW_HAVE_PEER_NANOFLANN
  m.push_back("nanoflann-1.12.1");
#endif
#ifdef DW_HAVE_PEER_PICO_TREE
  m.push_back("pico_tree");
#endif
  return m;
}

std::unique_ptr<SelfQueries> makeMethod(const std::string& name, const Fixture& f) {
  if (name == "walk-core") return std::make_unique<WalkCore>(f);
  if (name == "walk-caller") return std::make_unique<WalkCaller>(f);
#ifdef DW_HAVE_PEER_NANOFLANN
  if (name == "nanoflann-1.12.1") return std::make_unique<NanoflannPeer>(f);
#endif
#ifdef DW_HAVE_PEER_PICO_TREE
  if (name == "pico_tree") return std::make_unique<PicoTreePeer>(f);
#endif
  return nullptr;
}

/// Queries (out of every 7th point) whose sorted distances differ from the reference method's beyond
/// float rounding: walk-core measures in the graph's local frame, the others in the caller's, and
/// the two differ by up to ~2^-22 (4 M d + 2 d^2) for coordinates of magnitude M (see
/// dw::CallerMetricSearch::tolerance); allowed twice that.
std::size_t mismatches(SelfQueries& m, SelfQueries& ref, std::size_t k, const Fixture& f) {
  std::vector<float> a, b;
  std::size_t bad = 0;
  float extent = 0.f;
  for (float c : f.xyz) extent = std::max(extent, std::fabs(c));
  for (std::size_t i = 0; i < f.size(); i += 7) {
    m.query(i, k, a);
    ref.query(i, k, b);
    bool ok = true;
    // Radius: a point within rounding of the sphere may fall either side; compare the common prefix.
    if (k > 0 && a.size() != b.size()) ok = false;
    if (k == 0 && std::max(a.size(), b.size()) - std::min(a.size(), b.size()) > 1) ok = false;
    for (std::size_t j = 0; ok && j < std::min(a.size(), b.size()); ++j)
      ok = std::fabs(a[j] - b[j]) <= 0x1p-21f * (4.f * extent * std::sqrt(b[j]) + 2.f * b[j]) + 1e-30f;
    bad += !ok;
  }
  return bad;
}

/// ns per query of every run, for the ratio table printed at the end.
std::map<std::string, std::map<std::string, double>>& results() {
  static std::map<std::string, std::map<std::string, double>> r;
  return r;
}

void benchSelf(benchmark::State& state, std::string data, std::string method, std::size_t k) {
  const Fixture& f = *fixtures().at(data);
  auto m = makeMethod(method, f);
  std::vector<float> sink(f.size());
  std::size_t total = 0;
  for (auto _ : state) {
    m->all(k, sink);
    benchmark::DoNotOptimize(sink.data());
    benchmark::ClobberMemory();
  }
  const double q = double(f.size());
  state.counters["ns_per_query"] = benchmark::Counter(
      q * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
#ifdef DW_HAVE_PEER_NANOFLANN
  std::unique_ptr<SelfQueries> ref = makeMethod("nanoflann-1.12.1", f);
#else
  std::unique_ptr<SelfQueries> ref = makeMethod("walk-core", f);
#endif
  state.counters["mismatches"] = double(mismatches(*m, *ref, k, f));
  if (k == 0) {
    std::vector<float> d2;
    for (std::size_t i = 0; i < f.size(); i += 7) m->query(i, 0, d2), total += d2.size();
    state.counters["mean_results"] = double(total) / double((f.size() + 6) / 7);
  }
}

std::string testName(const std::string& data, std::size_t k) {
  return k > 0 ? "kNN/" + data + "/k:" + std::to_string(k) : "Radius/" + data;
}

/// Keeps each run's ns/query for the ratio table.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      // With repetitions, the median stands for the run.
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name != "median") continue;
      const auto it = r.counters.find("ns_per_query");
      if (it == r.counters.end()) continue;
      std::string name = r.run_name.str();
      const std::string suffix = "/process_time";
      if (name.size() > suffix.size() &&
          name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
        name.resize(name.size() - suffix.size());
      const auto slash = name.find_last_of('/');
      results()[name.substr(0, slash)][name.substr(slash + 1)] = it->second.value;
    }
    ConsoleReporter::ReportRuns(runs);
  }
};

void printRatios() {
  std::printf("\n%-24s %-18s %12s %12s %12s\n", "test", "method", "ns/query", "/walk-core", "/walk-caller");
  for (const auto& [test, by_method] : results()) {
    const auto core = by_method.find("walk-core");
    const auto caller = by_method.find("walk-caller");
    for (const auto& [method, ns] : by_method) {
      std::printf("%-24s %-18s %12.1f", test.c_str(), method.c_str(), ns);
      if (core != by_method.end()) std::printf(" %12.2f", ns / core->second);
      if (caller != by_method.end()) std::printf(" %12.2f", ns / caller->second);
      std::printf("\n");
    }
  }
  std::printf("(a ratio above 1: that method is slower than the walk's)\n");
}

}  // namespace

int main(int argc, char** argv) {
  const char* env = std::getenv("DW_BENCH_DATASETS");
  const auto datasets = splitList(env ? env : "kitti,dragon-23k");
#ifndef DW_HAVE_PEER_NANOFLANN
  std::fprintf(stderr, "bench_knn_core: nanoflann 1.12.1 not found (DW_PEERS_DIR); peer skipped\n");
#endif
#ifndef DW_HAVE_PEER_PICO_TREE
  std::fprintf(stderr, "bench_knn_core: pico_tree not found (DW_PEERS_DIR); peer skipped\n");
#endif
  for (const auto& d : datasets) {
    try {
      fixtures()[d] = load(d);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench_knn_core: skipping %s: %s\n", d.c_str(), e.what());
      continue;
    }
    for (std::size_t k : {std::size_t(8), std::size_t(16), std::size_t(32), std::size_t(0)})
      for (const auto& m : methodNames()) {
        benchmark::RegisterBenchmark((testName(d, k) + "/" + m).c_str(), benchSelf, d, m, k)
            ->Unit(benchmark::kMillisecond)
            ->MeasureProcessCPUTime();
      }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  printRatios();
  benchmark::Shutdown();
  return 0;
}
