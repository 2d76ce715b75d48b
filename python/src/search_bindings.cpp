// NeighbourSearch: batch nearest / kNN / radius queries over a DelaunayGraph. Each batch releases the
// GIL and runs dw::parallelFor over contiguous blocks of queries on the module's kept threads
// (batch_team.h); queries are read in place from any float32/float64 (n, 3) layout and results
// written straight into the NumPy outputs.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "arrays.h"
#include "batch_team.h"
#include "bindings.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/core/search/query_order.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw_py {

namespace {

using dw::index_t;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::size_t kMinBlock = 1024;  // queries per worker below which another thread costs more
constexpr std::size_t kPrefetchAhead = 8;

/// What every query of a batch shares: the search, the queries, the hints and the strategy.
struct Batch {
  const dw::NeighbourSearch& search;
  const Points& queries;
  const std::int64_t* hints;  ///< null: none
  dw::StartStrategy strategy;
  unsigned workers;
  /// Run hinted queries grouped by start vertex; false where results are appended in query order.
  bool group_by_start = true;
};

dw::StartStrategy strategyArg(const py::object& name, bool have_hints) {
  if (name.is_none()) return have_hints ? dw::StartStrategy::PnnOptimized : dw::StartStrategy::KdAnn;
  return dw::parseStartStrategy(name.cast<std::string>());
}

/// Query i of a C-contiguous float32 (n, 3) array, whose rows are 12 bytes apart: loads at a
/// compile-time stride, and one finiteness test on the floats, exact (x - x is 0 for every finite x and
/// NaN for inf and NaN, and a NaN makes the sum NaN) instead of three on the doubles.
inline bool packedFloatQuery(const Points& q, std::size_t i, double& x, double& y, double& z) {
  const float* r = reinterpret_cast<const float*>(q.data) + 3 * i;
  const float a = r[0], b = r[1], c = r[2];
  x = a, y = b, z = c;
  return (a - a) + (b - b) + (c - c) == 0.0f;
}

/// Calls per_query(i, local_query, hint) for every finite query and skip(i) for the others, on the
/// batch's workers; T is the queries' dtype, kPacked whether they are a C-contiguous float32 (n, 3)
/// array (packedFloatQuery). With hints the queries run grouped by start vertex
/// (dw::orderByStartVertex, as the C++ ICP estimator runs them): the graph is stored along a
/// space-filling curve, so consecutive walks then read neighbouring records instead of a cache miss
/// each, whatever order the caller's points are in. Answers are written by position, so the order
/// changes no result; each worker's block is a contiguous range of that order.
template <typename T, bool kPacked, typename PerQuery, typename Skip>
void forEachQuery(const Batch& b, PerQuery&& per_query, Skip&& skip) {
  const dw::DelaunayGraph& g = b.search.graph();
  const Points& q = b.queries;
  std::vector<index_t> order;
  const bool grouped = b.hints && b.group_by_start;
  if (grouped) {
    std::vector<index_t> start(q.n);
    for (std::size_t i = 0; i < q.n; ++i) start[i] = hintVertex(b.hints[i]);
    order = dw::orderByStartVertex(start.data(), q.n, g.numVertices());
  }
  const bool empty = g.numVertices() == 0;
  // One block loop per hinted / not hinted, so that a batch without hints carries no hint branches.
  auto block = [&](auto hinted_tag, std::size_t begin, std::size_t end, unsigned w) {
    constexpr bool kHinted = decltype(hinted_tag)::value;
    for (std::size_t k = begin; k < end; ++k) {
      const std::size_t i = kHinted && grouped ? order[k] : k;
      // ICP-like sequences start at their hint, a cache miss on most queries: fetch it early.
      if (kHinted && k + kPrefetchAhead < end)
        b.search.prefetchStart(hintVertex(b.hints[grouped ? order[k + kPrefetchAhead] : k + kPrefetchAhead]));
      double x, y, z;
      bool finite;
      if constexpr (kPacked) {
        finite = packedFloatQuery(q, i, x, y, z);
      } else {
        x = q.at<T>(i, 0), y = q.at<T>(i, 1), z = q.at<T>(i, 2);
        finite = std::isfinite(x) && std::isfinite(y) && std::isfinite(z);
      }
      if (empty || !finite) {
        skip(i);
        continue;
      }
      per_query(i, g.toLocal(x, y, z), kHinted ? hintVertex(b.hints[i]) : dw::kInvalidIndex, w);
    }
  };
  dw::parallelFor(q.n, b.workers, [&](std::size_t begin, std::size_t end, unsigned w) {
    if (b.hints)
      block(std::true_type{}, begin, end, w);
    else
      block(std::false_type{}, begin, end, w);
  });
}

inline bool isPackedFloat(const Points& q) {
  return !q.is_double && q.row_stride == 3 * static_cast<py::ssize_t>(sizeof(float)) &&
         q.col_stride == static_cast<py::ssize_t>(sizeof(float));
}

template <typename PerQuery, typename Skip>
void dispatch(const Batch& b, PerQuery&& per_query, Skip&& skip) {
  const Points& q = b.queries;
  if (q.is_double)
    forEachQuery<double, false>(b, per_query, skip);
  else if (isPackedFloat(q))
    forEachQuery<float, true>(b, per_query, skip);
  else
    forEachQuery<float, false>(b, per_query, skip);
}

/// The batch nearest() of C-contiguous float32 queries without hints (the common NumPy call), as one
/// loop per worker block: the walk inlined into it (flatten), no per-query call, so the loop body is
/// the C++ caller's own plus the finiteness test and the `ends` store.
void nearestPackedWithoutHints(const Batch& b, std::int64_t* idx, float* d2, std::int64_t* end) {
  const dw::NeighbourSearch& s = b.search;
  const dw::DelaunayGraph& g = s.graph();
  const bool empty = g.numVertices() == 0;
  auto block = [&](std::size_t begin, std::size_t stop, unsigned) __attribute__((flatten)) {
    for (std::size_t i = begin; i < stop; ++i) {
      double x, y, z;
      if (empty || !packedFloatQuery(b.queries, i, x, y, z)) {
        idx[i] = -1, d2[i] = kInf, end[i] = -1;
        continue;
      }
      const dw::WalkResult r = s.nearest(g.toLocal(x, y, z), b.strategy);
      idx[i] = g.representative(r.vertex);
      d2[i] = r.dist2;
      end[i] = r.vertex;
    }
  };
  dw::parallelFor(b.queries.n, b.workers, block);
}

py::tuple nearest(const dw::NeighbourSearch& s, py::handle queries, py::handle hints_obj,
                  const py::object& strategy, unsigned threads) {
  const Points q = pointsArg(queries, "queries");
  const bool have_hints = !hints_obj.is_none();
  const py::array_t<std::int64_t> hints = have_hints ? hintsArg(hints_obj, q.n) : py::array_t<std::int64_t>();
  const Batch b{s, q, have_hints ? hints.data() : nullptr, strategyArg(strategy, have_hints),
                dw::workerCount(q.n, threads, kMinBlock)};
  const auto n = static_cast<py::ssize_t>(q.n);
  py::array_t<std::int64_t> indices(n), ends(n);
  py::array_t<float> dist2(n);
  std::int64_t* const idx = indices.mutable_data();
  std::int64_t* const end = ends.mutable_data();
  float* const d2 = dist2.mutable_data();
  if (!have_hints && isPackedFloat(q)) {
    {
      py::gil_scoped_release release;
      const BatchTeam team(b.workers);
      nearestPackedWithoutHints(b, idx, d2, end);
    }
    return py::make_tuple(indices, dist2, ends);
  }
  {
    py::gil_scoped_release release;
    const BatchTeam team(b.workers);
    const dw::DelaunayGraph& g = s.graph();
    // flatten: dw::walk is called from many instantiations in this module, so GCC keeps it out of line
    // here (a call, the result spilled to the stack, loads the inlined walk keeps in registers); the
    // C++ loop it is compared with has it inlined. Inlining the walk and its edge scan into this one
    // body gives the batch the same hot loop.
    dispatch(
        b,
        [&](std::size_t i, const dw::Vec3f& ql, index_t hint, unsigned) __attribute__((flatten)) {
          const dw::WalkResult r = s.nearest(ql, b.strategy, hint);
          idx[i] = g.representative(r.vertex);
          d2[i] = r.dist2;
          end[i] = r.vertex;
        },
        [&](std::size_t i) {
          idx[i] = -1;
          d2[i] = kInf;
          end[i] = b.hints ? b.hints[i] : -1;  // a skipped query keeps its hint for the next round
        });
  }
  return py::make_tuple(indices, dist2, ends);
}

py::tuple knn(const dw::NeighbourSearch& s, py::handle queries, py::ssize_t k, py::handle hints_obj,
              const py::object& strategy, unsigned threads) {
  if (k < 1) throw py::value_error("k must be at least 1, got " + std::to_string(k));
  const Points q = pointsArg(queries, "queries");
  const bool have_hints = !hints_obj.is_none();
  const py::array_t<std::int64_t> hints = have_hints ? hintsArg(hints_obj, q.n) : py::array_t<std::int64_t>();
  const Batch b{s, q, have_hints ? hints.data() : nullptr, strategyArg(strategy, have_hints),
                dw::workerCount(q.n, threads, kMinBlock)};
  const auto n = static_cast<py::ssize_t>(q.n);
  py::array_t<std::int64_t> indices({n, k});
  py::array_t<float> dist2({n, k});
  std::int64_t* const idx = indices.mutable_data();
  float* const d2 = dist2.mutable_data();
  const auto kk = static_cast<std::size_t>(k);
  auto pad = [&](std::size_t i, std::size_t from) {  // fewer than k finite points: -1 at distance inf
    for (std::size_t j = from; j < kk; ++j) idx[i * kk + j] = -1, d2[i * kk + j] = kInf;
  };
  {
    py::gil_scoped_release release;
    const BatchTeam team(b.workers);
    std::vector<std::vector<index_t>> found(b.workers);  // one result buffer per worker, reused
    std::vector<std::vector<float>> found_d2(b.workers);
    dispatch(
        b,
        [&](std::size_t i, const dw::Vec3f& ql, index_t hint, unsigned w) {
          const std::size_t m = s.knn(ql, kk, s.nearest(ql, b.strategy, hint), found[w], found_d2[w]);
          for (std::size_t j = 0; j < m; ++j) idx[i * kk + j] = found[w][j], d2[i * kk + j] = found_d2[w][j];
          pad(i, m);
        },
        [&](std::size_t i) { pad(i, 0); });
  }
  return py::make_tuple(indices, dist2);
}

/// Radius results of one worker's block of queries, in query order.
struct RaggedPart {
  std::vector<std::int64_t> indices;
  std::vector<float> dist2;
  std::vector<index_t> scratch;
  std::vector<float> scratch_d2;
};

py::tuple radius(const dw::NeighbourSearch& s, py::handle queries, double r, std::size_t max_nn,
                 py::handle hints_obj, const py::object& strategy, unsigned threads) {
  if (!(r >= 0.0)) throw py::value_error("r must be a non-negative number, got " + std::to_string(r));
  const Points q = pointsArg(queries, "queries");
  const bool have_hints = !hints_obj.is_none();
  const py::array_t<std::int64_t> hints = have_hints ? hintsArg(hints_obj, q.n) : py::array_t<std::int64_t>();
  const Batch b{s,
                q,
                have_hints ? hints.data() : nullptr,
                strategyArg(strategy, have_hints),
                dw::workerCount(q.n, threads, kMinBlock),
                /*group_by_start=*/false};
  const auto radius2 = static_cast<float>(r * r);
  py::array_t<std::int64_t> offsets(static_cast<py::ssize_t>(q.n + 1));
  std::int64_t* const off = offsets.mutable_data();
  std::vector<RaggedPart> parts(b.workers);
  {
    py::gil_scoped_release release;
    const BatchTeam team(b.workers);
    off[0] = 0;
    dispatch(
        b,
        [&](std::size_t i, const dw::Vec3f& ql, index_t hint, unsigned w) {
          RaggedPart& p = parts[w];
          const std::size_t m =
              s.radius(ql, radius2, s.nearest(ql, b.strategy, hint), p.scratch, p.scratch_d2, max_nn);
          p.indices.insert(p.indices.end(), p.scratch.begin(), p.scratch.begin() + m);
          p.dist2.insert(p.dist2.end(), p.scratch_d2.begin(), p.scratch_d2.begin() + m);
          off[i + 1] = static_cast<std::int64_t>(m);
        },
        [&](std::size_t i) { off[i + 1] = 0; });
    for (std::size_t i = 0; i < q.n; ++i) off[i + 1] += off[i];
  }
  // parallelFor's blocks are contiguous and ordered by worker, so the parts concatenate in query order.
  const auto total = static_cast<py::ssize_t>(off[q.n]);
  py::array_t<std::int64_t> indices(total);
  py::array_t<float> dist2(total);
  std::int64_t* idx = indices.mutable_data();
  float* d2 = dist2.mutable_data();
  for (const RaggedPart& p : parts) {
    idx = std::copy(p.indices.begin(), p.indices.end(), idx);
    d2 = std::copy(p.dist2.begin(), p.dist2.end(), d2);
  }
  return py::make_tuple(offsets, indices, dist2);
}

}  // namespace

void bindSearch(py::module_& m) {
  py::class_<dw::NeighbourSearch, std::shared_ptr<dw::NeighbourSearch>> c(m, "NeighbourSearch", R"doc(
Exact nearest, k-nearest and radius search over a DelaunayGraph (which it keeps alive).

Results are input indices of the graph's points (a duplicate point is reported as its smallest input
index by nearest(); knn() and radius() list every copy) and squared distances in the graph's local
frame. Batch calls release the GIL and run on `threads` threads (0: all). Non-finite queries give
index -1 and distance inf.)doc");
  c.def(py::init([](std::shared_ptr<dw::DelaunayGraph> g) {
          if (!g) throw py::type_error("NeighbourSearch needs a DelaunayGraph, got None");
          return std::make_shared<dw::NeighbourSearch>(std::move(g));
        }),
        py::arg("graph"));
  c.def_property_readonly(
      "graph",
      [](const dw::NeighbourSearch& s) { return std::const_pointer_cast<dw::DelaunayGraph>(s.graphPtr()); },
      "The searched graph.");
  c.def("nearest", &nearest, py::arg("queries"), py::arg("hints") = py::none(),
        py::arg("strategy") = py::none(), py::arg("threads") = 0u, R"doc(
Exact nearest neighbour of each query: (indices int64 (n,), sq_dists float32 (n,), ends int64 (n,)).

`ends` are the walks' end vertices; pass them back as `hints` for the next, nearby batch (ICP). The
strategy is 'zero', 'kd-ann', 'pnn' or 'pnn-optimized'; default 'pnn-optimized' with hints, else 'kd-ann'.)doc");
  c.def("knn", &knn, py::arg("queries"), py::arg("k"), py::arg("hints") = py::none(),
        py::arg("strategy") = py::none(), py::arg("threads") = 0u, R"doc(
Exact k nearest input points of each query, ascending distance: (indices int64 (n,k), sq_dists float32
(n,k)); rows with fewer than k finite points are padded with -1 and inf.)doc");
  c.def("radius", &radius, py::arg("queries"), py::arg("r"), py::arg("max_nn") = 0,
        py::arg("hints") = py::none(), py::arg("strategy") = py::none(), py::arg("threads") = 0u, R"doc(
Every input point within distance r (squared distance <= float32(r*r)), ascending, at most max_nn (the
nearest; 0: no limit): (offsets int64 (n+1,), indices int64, sq_dists float32), the results of query i
being indices[offsets[i]:offsets[i+1]].)doc");
}

}  // namespace dw_py
