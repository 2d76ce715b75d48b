/// \file stream_tin.cpp
/// \brief The streaming TIN's step: merge, triangulate, remove what lies under the final region, split,
/// hand on, keep the frontier and the resident points (see stream_tin.h for why it is exact).
#include "core/dem/stream_tin.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <unordered_set>

#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace dem {
namespace detail {

namespace {

constexpr index_t kNoTriangle = ~index_t(0);

std::uint64_t edgeKey(index_t a, index_t b) {
  return (std::uint64_t(a) << 32) | b;
}

/// The two sorted point sets merged into one in ascending global index.
StripPoints mergeByIndex(StripPoints& a, StripPoints& b) {
  StripPoints out;
  const std::size_t n = a.size() + b.size();
  out.x.reserve(n), out.y.reserve(n), out.value.reserve(n), out.index.reserve(n);
  std::size_t i = 0, j = 0;
  while (i < a.size() || j < b.size()) {
    const bool take_a = j == b.size() || (i < a.size() && a.index[i] < b.index[j]);
    StripPoints& s = take_a ? a : b;
    std::size_t& k = take_a ? i : j;
    out.x.push_back(s.x[k]), out.y.push_back(s.y[k]), out.value.push_back(s.value[k]);
    out.index.push_back(s.index[k]);
    ++k;
  }
  a.clear(), b.clear();
  return out;
}

/// Directed edges of a triangulation by their first vertex: find(a, b) is the triangle holding a -> b.
/// Built on `threads` threads: the counts and slots are claimed atomically, so the order of a vertex's
/// entries varies, but every directed edge is in one triangle and find() gives the same answer.
class EdgeIndex {
 public:
  EdgeIndex(const std::vector<index_t>& t, std::size_t n, unsigned threads) : start_(n + 1, 0) {
    const unsigned workers = workerCount(t.size(), threads, 1 << 16);
    entries_.resize(t.size());
    auto entry = [&](std::size_t k) {
      const std::size_t tri = k / 3, next = 3 * tri + (k % 3 + 1) % 3;
      return std::pair<index_t, index_t>(t[next], index_t(tri));
    };
    if (workers <= 1) {
      for (std::size_t k = 0; k < t.size(); ++k) ++start_[t[k] + 1];
      for (std::size_t v = 0; v < n; ++v) start_[v + 1] += start_[v];
      std::vector<index_t> fill(start_.begin(), start_.end() - 1);
      for (std::size_t k = 0; k < t.size(); ++k) entries_[fill[t[k]]++] = entry(k);
      return;
    }
    std::vector<std::atomic<index_t>> slot(n + 1);
    parallelFor(n + 1, workers, [&](std::size_t b, std::size_t e, unsigned) {
      for (std::size_t v = b; v < e; ++v) slot[v].store(0, std::memory_order_relaxed);
    });
    parallelFor(t.size(), workers, [&](std::size_t b, std::size_t e, unsigned) {
      for (std::size_t k = b; k < e; ++k) slot[t[k] + 1].fetch_add(1, std::memory_order_relaxed);
    });
    for (std::size_t v = 0; v < n; ++v) {
      start_[v + 1] = start_[v] + slot[v + 1].load(std::memory_order_relaxed);
      slot[v].store(start_[v], std::memory_order_relaxed);
    }
    parallelFor(t.size(), workers, [&](std::size_t b, std::size_t e, unsigned) {
      for (std::size_t k = b; k < e; ++k) entries_[slot[t[k]].fetch_add(1, std::memory_order_relaxed)] = entry(k);
    });
  }
  index_t find(index_t a, index_t b) const {
    for (index_t e = start_[a]; e < start_[a + 1]; ++e)
      if (entries_[e].first == b) return entries_[e].second;
    return kNoTriangle;
  }

  /// Marks the vertices of the boundary (the convex hull of the triangulated points), walked from
  /// vertex `start` on it: each boundary vertex has one out-edge without its reverse (its triangles
  /// form one fan), the next boundary edge counter-clockwise.
  void markBoundary(index_t start, std::vector<char>& on) const {
    index_t v = start;
    for (std::size_t steps = 0; steps <= entries_.size(); ++steps) {
      on[v] = 1;
      index_t next = kNoTriangle;
      for (index_t e = start_[v]; e < start_[v + 1] && next == kNoTriangle; ++e)
        if (find(entries_[e].first, v) == kNoTriangle) next = entries_[e].first;
      if (next == kNoTriangle) throw Error("dw::dem: internal consistency failure (open boundary)");
      v = next;
      if (v == start) return;
    }
    throw Error("dw::dem: internal consistency failure (boundary walk)");
  }

 private:
  std::vector<index_t> start_;
  std::vector<std::pair<index_t, index_t>> entries_;
};

enum Label : unsigned char { kTrue = 0, kUnderFinal = 1, kFinal = 2, kOpen = 3 };

}  // namespace

void StreamTin::addStrip(StripPoints&& strip, double seam, const FinalTriangles& emit) {
  StripPoints pts = mergeByIndex(resident_, strip);
  const std::size_t n = pts.size();
  if (n == 0) return;
  tin::TinOptions to;
  to.num_threads = threads_;
  tin::TinResult tin = tin::triangulate(pts.x.data(), pts.y.data(), n, to);
  if (tin.degenerate) {  // collinear so far: every distinct point stays
    std::vector<char> dup(n, 0);
    for (const auto& d : tin.duplicates) dup[d.first] = 1;
    for (std::size_t i = 0; i < n; ++i)
      if (!dup[i]) {
        resident_.x.push_back(pts.x[i]), resident_.y.push_back(pts.y[i]);
        resident_.value.push_back(pts.value[i]), resident_.index.push_back(pts.index[i]);
      }
    return;
  }
  const std::vector<index_t>& t = tin.triangles;
  const std::size_t nt = t.size() / 3;
  const EdgeIndex edges(t, n, threads_);
  auto local = [&](std::uint64_t g) {
    const auto it = std::lower_bound(pts.index.begin(), pts.index.end(), g);
    if (it == pts.index.end() || *it != g)
      throw Error("dw::dem: internal consistency failure (frontier vertex)");
    return index_t(it - pts.index.begin());
  };
  std::vector<std::pair<index_t, index_t>> old_frontier;
  std::unordered_set<std::uint64_t> old_set;
  for (const auto& e : frontier_) {
    old_frontier.emplace_back(local(e.first), local(e.second));
    old_set.insert(edgeKey(old_frontier.back().first, old_frontier.back().second));
  }

  // Triangles under the final region: reached from the final side of a frontier edge.
  std::vector<unsigned char> label(nt, kTrue);
  std::vector<index_t> stack;
  for (const auto& e : old_frontier) {
    const index_t f = edges.find(e.first, e.second);
    if (f != kNoTriangle && label[f] == kTrue) label[f] = kUnderFinal, stack.push_back(f);
  }
  while (!stack.empty()) {
    const index_t f = stack.back();
    stack.pop_back();
    for (int j = 0; j < 3; ++j) {
      const index_t p = t[3 * f + j], q = t[3 * f + (j + 1) % 3];
      if (old_set.count(edgeKey(p, q))) continue;
      const index_t g = edges.find(q, p);
      if (g != kNoTriangle && label[g] == kTrue) label[g] = kUnderFinal, stack.push_back(g);
    }
  }

  // The rest, final or open.
  std::vector<index_t> live, fin, open;
  for (std::size_t k = 0; k < nt; ++k)
    if (label[k] == kTrue) live.insert(live.end(), {t[3 * k], t[3 * k + 1], t[3 * k + 2]});
  splitFinalTriangles(pts.x.data(), pts.y.data(), live.data(), live.size(), seam, hull_, fin, open, threads_);
  std::size_t fi = 0;  // the split keeps the order: each live triangle is the next final one or open
  for (std::size_t k = 0; k < nt; ++k) {
    if (label[k] != kTrue) continue;
    const bool is_final =
        fi < fin.size() && fin[fi] == t[3 * k] && fin[fi + 1] == t[3 * k + 1] && fin[fi + 2] == t[3 * k + 2];
    label[k] = is_final ? kFinal : kOpen;
    fi += is_final ? 3 : 0;
  }
  if (emit && !fin.empty()) emit(pts, fin);

  // The new frontier: old frontier edges and final triangles' edges whose other side is not final.
  std::vector<char> keep(n, 0);
  for (std::size_t k = 0; k < open.size(); ++k) keep[open[k]] = 1;
  auto isFrontier = [&](index_t a, index_t b) {
    const index_t across = edges.find(b, a);
    if (across != kNoTriangle) return label[across] == kOpen;
    if (old_set.count(edgeKey(b, a))) return false;
    // A hull edge: stays on the frontier while a later point may come outside it.
    return laterPointsMayLieRightOf(pts.x[a], pts.y[a], pts.x[b], pts.y[b], seam, hull_);
  };
  // An edge of a final triangle with an open triangle across has two vertices of open triangles; one
  // with none across is a boundary edge. Only such edges need the look-up.
  std::vector<char> boundary(n, 0);
  {
    index_t lowest = kNoTriangle;  // the lexicographically smallest vertex of a triangle is on the hull
    for (std::size_t k = 0; k < t.size(); ++k) {
      const index_t v = t[k];
      if (lowest == kNoTriangle || pts.x[v] < pts.x[lowest] || (pts.x[v] == pts.x[lowest] && pts.y[v] < pts.y[lowest]))
        lowest = v;
    }
    edges.markBoundary(lowest, boundary);
  }
  auto mayBeFrontier = [&](index_t a, index_t b) { return (keep[a] && keep[b]) || (boundary[a] && boundary[b]); };
  std::vector<std::pair<index_t, index_t>> found;
  for (const auto& e : old_frontier)
    if (isFrontier(e.first, e.second)) found.push_back(e);
  // The final triangles' edges in blocks, appended in block order (the same list for any thread count).
  const std::size_t nf = fin.size() / 3;
  const unsigned workers = workerCount(nf, threads_, 16384);
  std::vector<std::vector<std::pair<index_t, index_t>>> per(workers);
  parallelFor(nf, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    for (std::size_t k = 3 * b; k < 3 * e; k += 3)
      for (int j = 0; j < 3; ++j)
        if (mayBeFrontier(fin[k + j], fin[k + (j + 1) % 3]) && isFrontier(fin[k + j], fin[k + (j + 1) % 3]))
          per[w].emplace_back(fin[k + j], fin[k + (j + 1) % 3]);
  });
  for (const auto& v : per) found.insert(found.end(), v.begin(), v.end());
  std::vector<std::pair<std::uint64_t, std::uint64_t>> next;
  next.reserve(found.size());
  for (const auto& e : found) {
    next.emplace_back(pts.index[e.first], pts.index[e.second]);
    keep[e.first] = keep[e.second] = 1;
  }
  frontier_.swap(next);

  for (std::size_t i = 0; i < n; ++i)
    if (keep[i]) {
      resident_.x.push_back(pts.x[i]), resident_.y.push_back(pts.y[i]);
      resident_.value.push_back(pts.value[i]), resident_.index.push_back(pts.index[i]);
    }
}

}  // namespace detail
}  // namespace dem
}  // namespace dw
