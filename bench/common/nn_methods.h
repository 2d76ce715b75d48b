/// \file nn_methods.h
/// \brief The exact nearest-neighbour peers side by side behind one batch interface: brute force,
/// pcl::search::KdTree (FLANN), nanoflann, pcl::search::Octree, and the Delaunay walk with the seed's
/// four start strategies. A batch answers one ICP iteration (every source point), so the virtual call
/// is paid once per iteration, never per query, and each peer's inner loop is its own.
#pragma once

#include <pcl/common/common.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/search/octree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#ifdef DW_HAVE_NANOFLANN
#include <nanoflann.hpp>
static_assert(NANOFLANN_VERSION >= 0x140,
              "NanoflannNn relies on the constructor building the tree (nanoflann 1.4)");
#endif

#include "core/util/space_filling_curve.h"
#include "datasets.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/core/search/query_order.h"
#include "worker_pool.h"

namespace dwb {

using Clock = std::chrono::steady_clock;
inline double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// CPU seconds used by the whole process so far. On a machine shared with other jobs (ours has 2
/// cores and several builds running), the CPU time of a single-threaded measurement is a far steadier
/// estimate of its uncontended run time than the wall clock, which also counts time spent preempted.
inline double processCpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// Per-query results of one batch. `hint` is the method's own carry-over state for that query slot
/// (the walk's previous vertex: PNN); other methods ignore it.
struct NnBatch {
  std::vector<int> index;            ///< nearest reference point (index into the reference cloud)
  std::vector<float> dist2;          ///< its squared distance as the method computed it
  std::vector<dw::index_t> hint;     ///< PNN state, kInvalidIndex = none (first ICP iteration)
  std::vector<std::uint32_t> steps;  ///< walk moves per query (walks only)
  void resize(std::size_t n) {
    index.resize(n);
    dist2.resize(n);
    steps.assign(n, 0);
    if (hint.size() != n) hint.assign(n, dw::kInvalidIndex);
  }
  void resetHints() { std::fill(hint.begin(), hint.end(), dw::kInvalidIndex); }
};

class NnMethod {
 public:
  virtual ~NnMethod() = default;
  virtual std::string name() const = 0;
  /// Builds the structure over the reference points (xyz floats, all finite).
  virtual void build(const std::vector<float>& xyz) = 0;
  /// Nearest neighbour of each of the n queries, split over `threads` threads.
  void nearest(const float* queries, std::size_t n, NnBatch& out, unsigned threads = 1) {
    out.resize(n);
    threads = std::max(1u, std::min<unsigned>(threads, static_cast<unsigned>(n / 1024 + 1)));
    if (threads == 1) return nearestRange(queries, 0, n, out);
    // Contiguous chunks: each thread keeps its own run of source points, as a parallel ICP would.
    const std::size_t chunk = (n + threads - 1) / threads;
    WorkerPool::instance().run(threads, [&](unsigned t) {
      const std::size_t b = t * chunk, e = std::min(n, b + chunk);
      if (b < e) nearestRange(queries, b, e, out);
    });
  }
  /// Whether the method reports walk steps.
  virtual bool isWalk() const { return false; }
  /// Bytes of the built structure, where the method can tell (0: unknown).
  virtual std::size_t memoryBytes() const { return 0; }

 protected:
  virtual void nearestRange(const float* q, std::size_t begin, std::size_t end, NnBatch& out) = 0;
};

/// Exhaustive scan: the ground truth, and a peer only for small clouds (the seed's ~11k points).
class BruteForceNn : public NnMethod {
 public:
  std::string name() const override { return "brute-force"; }
  void build(const std::vector<float>& xyz) override { xyz_ = xyz; }
  std::size_t memoryBytes() const override { return xyz_.size() * sizeof(float); }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    const std::size_t n = xyz_.size() / 3;
    for (std::size_t i = b; i < e; ++i) {
      const float x = q[3 * i], y = q[3 * i + 1], z = q[3 * i + 2];
      float best = std::numeric_limits<float>::infinity();
      int bi = -1;
      for (std::size_t k = 0; k < n; ++k) {
        const float dx = xyz_[3 * k] - x, dy = xyz_[3 * k + 1] - y, dz = xyz_[3 * k + 2] - z;
        const float d = dx * dx + dy * dy + dz * dz;
        if (d < best) best = d, bi = static_cast<int>(k);
      }
      out.index[i] = bi;
      out.dist2[i] = best;
    }
  }

 private:
  std::vector<float> xyz_;
};

/// pcl::search::KdTree (FLANN, exact: one kd-tree, unlimited checks), queried exactly as PCL's
/// CorrespondenceEstimation does: nearestKSearch(point, 1, ...).
class PclKdTreeNn : public NnMethod {
 public:
  std::string name() const override { return "pcl-kdtree"; }
  void build(const std::vector<float>& xyz) override {
    cloud_ = toCloud(xyz);
    tree_.reset(new pcl::search::KdTree<pcl::PointXYZ>(false));
    tree_->setInputCloud(cloud_);
  }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    pcl::Indices idx(1);
    std::vector<float> d2(1);
    for (std::size_t i = b; i < e; ++i) {
      tree_->nearestKSearch(pcl::PointXYZ(q[3 * i], q[3 * i + 1], q[3 * i + 2]), 1, idx, d2);
      out.index[i] = idx[0];
      out.dist2[i] = d2[0];
    }
  }

 private:
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree_;
};

/// pcl::search::Octree (exact nearestKSearch). Its speed depends on the leaf size; we aim at a few
/// points per occupied leaf of a surface-like cloud: resolution = 2 x (bbox diagonal / sqrt(n)).
class PclOctreeNn : public NnMethod {
 public:
  std::string name() const override { return "pcl-octree"; }
  void build(const std::vector<float>& xyz) override {
    cloud_ = toCloud(xyz);
    const double n = std::max<double>(1.0, cloud_->size());
    // Surface-like clouds: spacing ~ sqrt(area / n), with the bbox diagonal squared for the area. The
    // factor (2) can be swept with DW_BENCH_OCTREE_FACTOR: the best differs by data set
    // (docs/benchmarks.md, "Nearest-neighbour search").
    double diag = 0;
    {
      Eigen::Vector4f lo, hi;
      pcl::getMinMax3D(*cloud_, lo, hi);
      diag = (hi - lo).head<3>().norm();
    }
    const char* factor = std::getenv("DW_BENCH_OCTREE_FACTOR");
    resolution_ = std::max(1e-6, (factor ? std::atof(factor) : 2.0) * diag / std::sqrt(n));
    tree_.reset(new pcl::search::Octree<pcl::PointXYZ>(resolution_));
    tree_->setInputCloud(cloud_);
  }
  double resolution() const { return resolution_; }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    pcl::Indices idx(1);
    std::vector<float> d2(1);
    for (std::size_t i = b; i < e; ++i) {
      tree_->nearestKSearch(pcl::PointXYZ(q[3 * i], q[3 * i + 1], q[3 * i + 2]), 1, idx, d2);
      out.index[i] = idx[0];
      out.dist2[i] = d2[0];
    }
  }

 private:
  double resolution_ = 0;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
  pcl::search::Octree<pcl::PointXYZ>::Ptr tree_;
};

#ifdef DW_HAVE_NANOFLANN
/// nanoflann's KDTreeSingleIndexAdaptor with L2_Simple (the metric it recommends for 3D), leaf size
/// 10 (its default), over the points in place through the adaptor interface.
///
/// With `sorted` (a control for the walks' batch order): each batch is answered grouped by the query
/// points' cells in a 32^3 Morton order over the reference's bounding box, the sort timed with the
/// queries. The walks'
/// estimator groups its batch by start vertex; this gives the tree the same kind of locality.
class NanoflannNn : public NnMethod {
 public:
  explicit NanoflannNn(bool sorted = false) : sorted_(sorted) {}
  std::string name() const override { return sorted_ ? "nanoflann-sorted" : "nanoflann"; }
  void build(const std::vector<float>& xyz) override {
    cloud_.xyz = xyz;
    // The constructor builds the tree (nanoflann >= 1.4; Debian 12 ships 1.4.2). An explicit
    // buildIndex() after it would build it twice.
    index_.reset(new Index(3, cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(10)));
    if (sorted_) {
      for (int d = 0; d < 3; ++d) lo_[d] = hi_[d] = xyz.empty() ? 0.f : xyz[d];
      for (std::size_t i = 0; i < xyz.size(); i += 3)
        for (int d = 0; d < 3; ++d)
          lo_[d] = std::min(lo_[d], xyz[i + d]), hi_[d] = std::max(hi_[d], xyz[i + d]);
    }
  }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    if (!sorted_) return answer(q, b, e, nullptr, out);
    // A counting sort on 32^3 Morton cells of the reference's box (queries outside it clamp to its
    // faces): O(n), like the walks' grouping by start vertex; std::sort on full keys cost more than
    // the locality saved.
    constexpr unsigned kBits = 5;
    std::vector<std::uint32_t> cell(e - b), first((std::size_t(1) << (3 * kBits)) + 1, 0);
    for (std::size_t i = b; i < e; ++i) {
      std::uint32_t c[3];
      for (int d = 0; d < 3; ++d) {
        const float extent = hi_[d] > lo_[d] ? hi_[d] - lo_[d] : 1.f;
        const float t = std::min(1.f, std::max(0.f, (q[3 * i + d] - lo_[d]) / extent));
        c[d] = static_cast<std::uint32_t>(t * float((1u << kBits) - 1));
      }
      cell[i - b] = static_cast<std::uint32_t>(dw::mortonKey(c[0], c[1], c[2]));
      ++first[cell[i - b] + 1];
    }
    for (std::size_t k = 1; k < first.size(); ++k) first[k] += first[k - 1];
    std::vector<std::uint32_t> order(e - b);
    for (std::size_t i = b; i < e; ++i) order[first[cell[i - b]]++] = static_cast<std::uint32_t>(i);
    answer(q, 0, order.size(), order.data(), out);
  }

 private:
  // Queries order[k] (or k itself) for k in [b, e).
  void answer(const float* q, std::size_t b, std::size_t e, const std::uint32_t* order, NnBatch& out) {
    for (std::size_t k = b; k < e; ++k) {
      const std::size_t i = order ? order[k] : k;
      std::uint32_t idx = 0;
      float d2 = 0;
      nanoflann::KNNResultSet<float, std::uint32_t> rs(1);
      rs.init(&idx, &d2);
      index_->findNeighbors(rs, q + 3 * i, nanoflann::SearchParams());
      out.index[i] = static_cast<int>(idx);
      out.dist2[i] = d2;
    }
  }

  struct Cloud {
    std::vector<float> xyz;
    std::size_t kdtree_get_point_count() const { return xyz.size() / 3; }
    float kdtree_get_pt(std::size_t i, std::size_t d) const { return xyz[3 * i + d]; }
    template <class BBox>
    bool kdtree_get_bbox(BBox&) const {
      return false;
    }
  };
  using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3,
                                                    std::uint32_t>;
  Cloud cloud_;
  std::unique_ptr<Index> index_;
  bool sorted_ = false;
  float lo_[3] = {0, 0, 0}, hi_[3] = {0, 0, 0};
};
#endif

/// The Delaunay walk (seed Alg. 1) on the core graph, with one start strategy. `builder` picks the
/// Delaunay builder of the graph (Auto: the project's incremental kernel when compiled in, else Qhull);
/// `shareGraph` lets the variants reuse one build.
///
/// With `prefetch`, the batch prefetches the neighbourhood of the next query's hint (PNN) while the
/// current query walks. Profiling showed why this matters: on dragon-23k about 30% of the PNN walk's
/// samples sit on the first load of the start vertex's edge records, a cache miss per query, because
/// ICP issues queries in source order while the graph is stored in Morton order. The hints of the
/// whole batch are known before it starts, so those misses can overlap the previous query's work.
/// With `sorted`, the batch is walked grouped by hint vertex (results still land in query order), so
/// consecutive walks touch nearby graph memory. Both are batch-level changes a correspondence
/// estimator can make without touching the walk.
class WalkNn : public NnMethod {
 public:
  explicit WalkNn(dw::StartStrategy s, bool prefetch = false, dw::BuilderType builder = dw::BuilderType::Auto,
                  bool sorted = false)
      : strategy_(s), prefetch_(prefetch), sorted_(sorted), builder_(builder) {}
  std::string name() const override {
    std::string n = std::string("walk-") + dw::toString(strategy_) + (sorted_ ? "-sorted" : "") +
                    (prefetch_ ? "-prefetch" : "");
    if (builder_ == dw::BuilderType::Qhull) n += "@qhull";
    if (builder_ == dw::BuilderType::Incremental) n += "@incremental";
    return n;
  }
  bool isWalk() const override { return true; }
  void build(const std::vector<float>& xyz) override {
    dw::BuildOptions o;
    o.num_threads = 1;
    o.builder = builder_;
    auto g = std::make_shared<dw::DelaunayGraph>(
        dw::buildDelaunayGraph(dw::PointView::fromFloat(xyz.data(), xyz.size() / 3), o));
    search_ = std::make_shared<dw::NeighbourSearch>(g);
  }
  void shareGraph(const WalkNn& other) { search_ = other.search_; }
  const dw::NeighbourSearch* search() const { return search_.get(); }
  std::size_t memoryBytes() const override { return search_ ? search_->graph().memoryBytes() : 0; }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    const dw::NeighbourSearch& s = *search_;
    const dw::DelaunayGraph& g = s.graph();
    const std::size_t nv = g.points.size();
    const dw::index_t* hints = out.hint.data();
    // Visit order: the batch's own order, or (sorted) grouped by hint vertex so that consecutive walks
    // start in nearby graph memory, as the registration estimator does (dw::orderByStartVertex).
    const std::size_t n = e - b;
    std::vector<dw::index_t> order_;  // per call: ranges of one batch run on concurrent threads
    if (sorted_ && n > 0) {
      order_ = dw::orderByStartVertex(hints + b, n, nv);
      for (dw::index_t& i : order_) i += static_cast<dw::index_t>(b);
    } else {
      order_.resize(n);
      for (std::size_t i = 0; i < n; ++i) order_[i] = static_cast<dw::index_t>(b + i);
    }
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = order_[k];
      if (prefetch_) {
        // Two stages: the CSR offset and position of the hint two queries ahead, then the edge
        // records (~15 x 20 bytes: five cache lines) of the hint one query ahead.
        if (k + 2 < n && hints[order_[k + 2]] < nv) {
          const dw::index_t h = hints[order_[k + 2]];
          __builtin_prefetch(&g.offsets[h]);
          __builtin_prefetch(&g.points[h]);
          __builtin_prefetch(&g.originals_offsets[h]);
        }
        if (k + 1 < n && hints[order_[k + 1]] < nv) {
          const char* p = reinterpret_cast<const char*>(g.edges.data() + g.offsets[hints[order_[k + 1]]]);
          for (int line = 0; line < 5; ++line) __builtin_prefetch(p + 64 * line);
        }
      }
      const dw::Vec3f p = g.toLocal(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
      const dw::WalkResult r = s.nearest(p, strategy_, out.hint[i]);
      out.hint[i] = r.vertex;
      out.steps[i] = r.steps;
      out.index[i] = static_cast<int>(g.representative(r.vertex));
      out.dist2[i] = r.dist2;
    }
  }

 private:
  dw::StartStrategy strategy_;
  bool prefetch_;
  bool sorted_ = false;
  dw::BuilderType builder_;
  std::shared_ptr<dw::NeighbourSearch> search_;
};

/// Method names in report order.
inline std::vector<std::string> allMethodNames() {
  return {
      "brute-force", "pcl-kdtree", "nanoflann",          "pcl-octree",        "walk-zero",
      "walk-kd-ann", "walk-pnn",   "walk-pnn-optimized", "walk-pnn-prefetch", "walk-pnn-optimized-prefetch"};
}

/// Creates a method by name; nullptr when it is not compiled in (nanoflann without the header).
inline std::unique_ptr<NnMethod> makeMethod(const std::string& name) {
  if (name == "brute-force") return std::make_unique<BruteForceNn>();
  if (name == "pcl-kdtree") return std::make_unique<PclKdTreeNn>();
  if (name == "pcl-octree") return std::make_unique<PclOctreeNn>();
  if (name == "nanoflann" || name == "nanoflann-sorted") {
#ifdef DW_HAVE_NANOFLANN
    return std::make_unique<NanoflannNn>(name == "nanoflann-sorted");
#else
    return nullptr;
#endif
  }
  if (name.rfind("walk-", 0) == 0) {
    // walk-<strategy>[-prefetch][@qhull|@incremental]
    std::string rest = name.substr(5);
    dw::BuilderType builder = dw::BuilderType::Auto;
    const auto at = rest.find('@');
    if (at != std::string::npos) {
      const std::string b = rest.substr(at + 1);
      if (b == "qhull")
        builder = dw::BuilderType::Qhull;
      else if (b == "incremental")
        builder = dw::BuilderType::Incremental;
      else
        throw dw::Error("dw_bench: unknown graph builder '" + b + "' in '" + name + "'");
      rest.resize(at);
    }
    auto strip = [&rest](const std::string& suffix) {
      const bool has = rest.size() > suffix.size() &&
                       rest.compare(rest.size() - suffix.size(), suffix.size(), suffix) == 0;
      if (has) rest.resize(rest.size() - suffix.size());
      return has;
    };
    const bool prefetch = strip("-prefetch");
    const bool sorted = strip("-sorted");
    return std::make_unique<WalkNn>(dw::parseStartStrategy(rest), prefetch, builder, sorted);
  }
  throw dw::Error("dw_bench: unknown method '" + name + "'");
}

/// Exactness check against a reference answer. A result counts as wrong when its true distance
/// (recomputed in double from the caller's floats) exceeds the reference's by more than the rounding
/// of the coordinates themselves: the walk compares distances in the graph's local float frame
/// (coordinates minus a double origin, rounded once), which can swap two points whose distances agree
/// to a few float ulps of the coordinates. Such ties at float resolution are not errors (measured:
/// 1 such swap in 2M queries on dragon-100k, distances equal to 1.7e-5 relative); a walk that stopped
/// early would be off by a point spacing, orders of magnitude more.
inline std::size_t countWrong(const std::vector<float>& ref_xyz, const float* q, std::size_t n,
                              const std::vector<int>& got, const std::vector<int>& want) {
  std::size_t wrong = 0;
  auto d2 = [&](std::size_t i, int k) {
    double s = 0;
    for (int a = 0; a < 3; ++a) {
      const double d = double(q[3 * i + a]) - double(ref_xyz[3 * std::size_t(k) + a]);
      s += d * d;
    }
    return s;
  };
  auto mag = [](const float* p) { return std::max({std::fabs(p[0]), std::fabs(p[1]), std::fabs(p[2])}); };
  for (std::size_t i = 0; i < n; ++i) {
    if (got[i] == want[i]) continue;
    if (got[i] < 0) {
      ++wrong;
      continue;
    }
    // Rounding of one coordinate difference, per axis, doubled for the two frames, over 3 axes.
    const double delta = 2.0 * 1.7320508 * std::numeric_limits<float>::epsilon() *
                         (mag(q + 3 * i) + mag(&ref_xyz[3 * std::size_t(want[i])]));
    const double bound = std::sqrt(d2(i, want[i])) + 2.0 * delta;
    if (d2(i, got[i]) > bound * bound) ++wrong;
  }
  return wrong;
}

}  // namespace dwb
