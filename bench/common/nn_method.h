/// \file nn_method.h
/// \brief The PCL-free half of the benchmarks' search interface: one batch interface for exact 1-NN,
/// kNN and radius search (a batch answers one ICP iteration or one pass over a cloud, so the virtual
/// call is paid per batch, never per query), brute force as the ground truth, and the Delaunay walk
/// with the seed's start strategies. The PCL peers are in nn_methods.h; the 2026 peers (nanoflann
/// 1.12.1, pico_tree, small_gicp) in bench/peers/.
#pragma once

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

/// Results of a kNN or radius batch. kNN: `k` slots per query (index -1 past the found ones), in
/// ascending distance. Radius: only `count` and `far2` (the farthest answer's squared distance) per
/// query: enough to compare methods, and what every method must compute anyway.
struct KnnBatch {
  std::size_t k = 0;
  std::vector<int> index;
  std::vector<float> dist2;
  std::vector<std::uint32_t> count;
  std::vector<float> far2;
  void resize(std::size_t n, std::size_t slots) {
    k = slots;
    index.assign(n * k, -1);
    dist2.assign(n * k, 0.f);
    count.assign(n, 0);
    far2.assign(n, 0.f);
  }
};

class NnMethod {
 public:
  virtual ~NnMethod() = default;
  virtual std::string name() const = 0;
  /// Library version, where it is a peer's ("1.12.1"); empty for our own code.
  virtual std::string version() const { return {}; }
  /// Builds the structure over the reference points (xyz floats, all finite).
  virtual void build(const std::vector<float>& xyz) = 0;
  /// Nearest neighbour of each of the n queries, split over `threads` threads.
  void nearest(const float* queries, std::size_t n, NnBatch& out, unsigned threads = 1) {
    out.resize(n);
    split(n, threads, [&](std::size_t b, std::size_t e) { nearestRange(queries, b, e, out); });
  }
  /// Whether knn() and radius() are implemented.
  virtual bool hasKnn() const { return false; }
  /// The k nearest reference points of each query. With self_stride s > 0, query i IS reference point
  /// i * s (self-queries, what NormalEstimation and GICP's covariances ask): a method may use that
  /// (the walk starts at the point's own vertex); the answers include the point itself.
  void knn(const float* queries, std::size_t n, std::size_t k, KnnBatch& out, unsigned threads = 1,
           std::size_t self_stride = 0) {
    out.resize(n, k);
    split(n, threads, [&](std::size_t b, std::size_t e) { knnRange(queries, b, e, k, self_stride, out); });
  }
  /// Every reference point within squared distance r2 of each query (counts and farthest only).
  void radius(const float* queries, std::size_t n, float r2, KnnBatch& out, unsigned threads = 1,
              std::size_t self_stride = 0) {
    out.resize(n, 0);
    split(n, threads,
          [&](std::size_t b, std::size_t e) { radiusRange(queries, b, e, r2, self_stride, out); });
  }
  /// Whether the method reports walk steps.
  virtual bool isWalk() const { return false; }
  /// Bytes of the built structure, where the method can tell (0: unknown).
  virtual std::size_t memoryBytes() const { return 0; }

 protected:
  virtual void nearestRange(const float* q, std::size_t begin, std::size_t end, NnBatch& out) = 0;
  virtual void knnRange(const float*, std::size_t, std::size_t, std::size_t, std::size_t, KnnBatch&) {
    throw dw::Error("dw_bench: " + name() + " has no kNN search here");
  }
  virtual void radiusRange(const float*, std::size_t, std::size_t, float, std::size_t, KnnBatch&) {
    throw dw::Error("dw_bench: " + name() + " has no radius search here");
  }
  /// Stores one query's sorted answers into its slots of `out` (kNN) or its count/farthest (radius).
  template <typename Index, typename Dist>
  static void store(KnnBatch& out, std::size_t i, const Index* idx, const Dist* d2, std::size_t found) {
    out.count[i] = static_cast<std::uint32_t>(found);
    out.far2[i] = found ? static_cast<float>(d2[found - 1]) : 0.f;
    for (std::size_t j = 0; j < std::min(found, out.k); ++j) {
      out.index[i * out.k + j] = static_cast<int>(idx[j]);
      out.dist2[i * out.k + j] = static_cast<float>(d2[j]);
    }
  }

 private:
  // Contiguous chunks: each thread keeps its own run of queries, as a parallel ICP would.
  template <typename F>
  static void split(std::size_t n, unsigned threads, const F& range) {
    threads = std::max(1u, std::min<unsigned>(threads, static_cast<unsigned>(n / 1024 + 1)));
    if (threads == 1) return range(0, n);
    const std::size_t chunk = (n + threads - 1) / threads;
    WorkerPool::instance().run(threads, [&](unsigned t) {
      const std::size_t b = t * chunk, e = std::min(n, b + chunk);
      if (b < e) range(b, e);
    });
  }
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
  bool hasKnn() const override { return true; }
  // kNN and radius expand best-first from the query's nearest vertex: a self-query's is its own vertex
  // (no walk), a foreign query's comes from a walk started by this method's strategy.
  void knnRange(const float* q, std::size_t b, std::size_t e, std::size_t k, std::size_t self,
                KnnBatch& out) override {
    std::vector<dw::index_t> idx;
    std::vector<float> d2;
    for (std::size_t i = b; i < e; ++i) {
      const dw::Vec3f p = search_->graph().toLocal(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
      const std::size_t found = search_->knn(p, k, start(p, i, self), idx, d2);
      store(out, i, idx.data(), d2.data(), found);
    }
  }
  void radiusRange(const float* q, std::size_t b, std::size_t e, float r2, std::size_t self,
                   KnnBatch& out) override {
    std::vector<dw::index_t> idx;
    std::vector<float> d2;
    for (std::size_t i = b; i < e; ++i) {
      const dw::Vec3f p = search_->graph().toLocal(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
      const std::size_t found = search_->radius(p, r2, start(p, i, self), idx, d2);
      store(out, i, idx.data(), d2.data(), found);
    }
  }

 private:
  // Query i of a self-query batch of stride s is input point i * s.
  dw::WalkResult start(const dw::Vec3f& p, std::size_t i, std::size_t self_stride) const {
    const dw::DelaunayGraph& g = search_->graph();
    const std::size_t input = i * self_stride;
    if (self_stride && input < g.input_to_vertex.size() && g.input_to_vertex[input] != dw::kInvalidIndex) {
      dw::WalkResult r;
      r.vertex = g.input_to_vertex[input];
      const dw::Vec3f d = g.points[r.vertex] - p;
      r.dist2 = dw::dot(d, d);
      return r;
    }
    return search_->nearest(p, strategy_ == dw::StartStrategy::Pnn ? dw::StartStrategy::KdAnn : strategy_);
  }
  dw::StartStrategy strategy_;
  bool prefetch_;
  bool sorted_ = false;
  dw::BuilderType builder_;
  std::shared_ptr<dw::NeighbourSearch> search_;
};

/// A walk by name: walk-<strategy>[-sorted][-prefetch][@qhull|@incremental], strategy one of zero,
/// kd-ann, pnn, pnn-optimized.
inline std::unique_ptr<WalkNn> makeWalk(const std::string& name) {
  if (name.rfind("walk-", 0) != 0) throw dw::Error("dw_bench: '" + name + "' is not a walk");
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
    const bool has =
        rest.size() > suffix.size() && rest.compare(rest.size() - suffix.size(), suffix.size(), suffix) == 0;
    if (has) rest.resize(rest.size() - suffix.size());
    return has;
  };
  const bool prefetch = strip("-prefetch");
  const bool sorted = strip("-sorted");
  return std::make_unique<WalkNn>(dw::parseStartStrategy(rest), prefetch, builder, sorted);
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
