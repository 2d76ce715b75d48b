/// \file stream_tin.cpp
/// \brief The streaming TIN's step: merge, triangulate, remove what lies under the final region, split,
/// hand on, keep the frontier and the resident points (see stream_tin.h for why it is exact).
#include "core/dem/stream_tin.h"

#include <algorithm>
#include <chrono>
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

/// The resident points and the strip merged into one set in ascending global index; `at` gets the
/// resident points' positions in it. The resident set is small: each strip point moves by the number
/// of resident points before it, found once per block.
StripPoints mergeByIndex(StripPoints& resident, StripPoints& strip, std::vector<index_t>& at,
                         unsigned threads) {
  at.clear();
  if (resident.size() == 0) return std::move(strip);
  StripPoints out;
  const std::size_t nr = resident.size(), ns = strip.size(), n = nr + ns;
  out.x.resize(n), out.y.resize(n), out.value.resize(n), out.index.resize(n);
  auto put = [&](const StripPoints& from, std::size_t i, std::size_t to) {
    out.x[to] = from.x[i], out.y[to] = from.y[i], out.value[to] = from.value[i],
    out.index[to] = from.index[i];
  };
  parallelFor(ns, workerCount(ns, threads, 1 << 16), [&](std::size_t b, std::size_t e, unsigned) {
    if (b == e) return;
    std::size_t r =
        std::size_t(std::lower_bound(resident.index.begin(), resident.index.end(), strip.index[b]) -
                    resident.index.begin());
    for (std::size_t j = b; j < e; ++j) {
      while (r < nr && resident.index[r] < strip.index[j]) ++r;
      put(strip, j, j + r);
    }
  });
  for (std::size_t i = 0; i < nr; ++i) {
    at.push_back(
        index_t(i + std::size_t(std::lower_bound(strip.index.begin(), strip.index.end(), resident.index[i]) -
                                strip.index.begin())));
    put(resident, i, at.back());
  }
  resident.clear(), strip.clear();
  return out;
}

/// The triangles k of t with keep(k), in order, gathered on `threads` threads.
template <class Keep>
std::vector<index_t> gatherTriangles(const std::vector<index_t>& t, Keep&& keep, unsigned threads) {
  const std::size_t nt = t.size() / 3;
  const unsigned workers = workerCount(nt, threads, 1 << 16);
  std::vector<std::size_t> offset(workers + 1, 0);
  parallelFor(nt, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    std::size_t c = 0;
    for (std::size_t k = b; k < e; ++k) c += keep(k) ? 1 : 0;
    offset[w + 1] = c;
  });
  for (unsigned w = 0; w < workers; ++w) offset[w + 1] += offset[w];
  std::vector<index_t> out(3 * offset[workers]);
  parallelFor(nt, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    index_t* o = out.data() + 3 * offset[w];
    for (std::size_t k = b; k < e; ++k)
      if (keep(k)) o[0] = t[3 * k], o[1] = t[3 * k + 1], o[2] = t[3 * k + 2], o += 3;
  });
  return out;
}

/// The triangles with a covered vertex, by vertex: find(a, b) is the triangle holding the directed
/// edge a -> b. Only the vertices the step asks about are covered (the resident points, the open
/// triangles' vertices, the hull's boundary): building the index for every vertex costs as much as
/// the strip's TIN. Asking about another vertex is an internal error, never a silent "no triangle".
class EdgeIndex {
 public:
  EdgeIndex(const std::vector<index_t>& t, const std::vector<char>& covered, unsigned threads)
      : id_(covered.size(), kNoTriangle) {
    for (std::size_t v = 0; v < covered.size(); ++v)
      if (covered[v]) id_[v] = index_t(start_.size()), start_.push_back(0);
    start_.push_back(0);
    const std::vector<index_t> touching = trianglesTouching(t, covered, threads);
    for (const index_t f : touching)
      for (int j = 0; j < 3; ++j)
        if (covered[t[3 * f + j]]) ++start_[id_[t[3 * f + j]] + 1];
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    std::vector<index_t> fill(start_.begin(), start_.end() - 1);
    entries_.resize(start_.back());
    for (const index_t f : touching)
      for (int j = 0; j < 3; ++j) {
        const index_t v = t[3 * f + j];
        if (covered[v]) entries_[fill[id_[v]]++] = {t[3 * f + (j + 1) % 3], t[3 * f + (j + 2) % 3], f};
      }
  }

  index_t find(index_t a, index_t b) const {
    const index_t c = idOf(a);
    for (index_t e = start_[c]; e < start_[c + 1]; ++e)
      if (entries_[e].next == b) return entries_[e].tri;
    return kNoTriangle;
  }

  bool hasTriangles(index_t v) const { return id_[v] != kNoTriangle && start_[id_[v] + 1] > start_[id_[v]]; }

  /// Marks the vertices of the boundary (the convex hull of the triangulated points), walked from
  /// vertex `start` on it: each boundary vertex has one out-edge without its reverse (its triangles
  /// form one fan), the next boundary edge counter-clockwise.
  void markBoundary(index_t start, std::vector<char>& on) const {
    index_t v = start;
    for (std::size_t steps = 0; steps <= entries_.size(); ++steps) {
      on[v] = 1;
      const index_t c = idOf(v);
      index_t next = kNoTriangle;
      for (index_t e = start_[c]; e < start_[c + 1] && next == kNoTriangle; ++e) {
        bool reversed = false;  // some triangle of v holds next -> v: its vertex before v is next
        for (index_t g = start_[c]; g < start_[c + 1] && !reversed; ++g)
          reversed = entries_[g].prev == entries_[e].next;
        if (!reversed) next = entries_[e].next;
      }
      if (next == kNoTriangle) throw Error("dw::dem: internal consistency failure (open boundary)");
      v = next;
      if (v == start) return;
    }
    throw Error("dw::dem: internal consistency failure (boundary walk)");
  }

 private:
  struct Entry {
    index_t next, prev, tri;  // the triangle's vertices after and before this one
  };

  index_t idOf(index_t v) const {
    if (id_[v] == kNoTriangle)
      throw Error("dw::dem: internal consistency failure (edge of an uncovered vertex)");
    return id_[v];
  }

  static std::vector<index_t> trianglesTouching(const std::vector<index_t>& t,
                                                const std::vector<char>& covered, unsigned threads) {
    const std::size_t nt = t.size() / 3;
    const unsigned workers = workerCount(nt, threads, 1 << 16);
    std::vector<std::vector<index_t>> per(workers);
    parallelFor(nt, workers, [&](std::size_t b, std::size_t e, unsigned w) {
      for (std::size_t f = b; f < e; ++f)
        if (covered[t[3 * f]] || covered[t[3 * f + 1]] || covered[t[3 * f + 2]]) per[w].push_back(index_t(f));
    });
    std::vector<index_t> out;
    for (const auto& v : per) out.insert(out.end(), v.begin(), v.end());
    return out;
  }

  std::vector<index_t> id_;     // compact number of a covered vertex, else kNoTriangle
  std::vector<index_t> start_;  // entries of compact vertex c: [start_[c], start_[c + 1])
  std::vector<Entry> entries_;
};

enum Label : unsigned char { kFinal = 0, kOpen = 1, kUnderFinal = 2 };

using Clock = std::chrono::steady_clock;
double since(Clock::time_point& t) {  // seconds since t; t becomes now
  const Clock::time_point now = Clock::now();
  const double s = std::chrono::duration<double>(now - t).count();
  t = now;
  return s;
}

/// The old frontier in local indices, as a list and as a set of edge keys.
struct LocalFrontier {
  std::vector<std::pair<index_t, index_t>> edges;
  std::unordered_set<std::uint64_t> keys;
  bool has(index_t a, index_t b) const { return keys.count(edgeKey(a, b)) != 0; }
};

LocalFrontier localFrontier(const StripPoints& pts,
                            const std::vector<std::pair<std::uint64_t, std::uint64_t>>& f) {
  auto local = [&](std::uint64_t g) {
    const auto it = std::lower_bound(pts.index.begin(), pts.index.end(), g);
    if (it == pts.index.end() || *it != g)
      throw Error("dw::dem: internal consistency failure (frontier vertex)");
    return index_t(it - pts.index.begin());
  };
  LocalFrontier out;
  for (const auto& e : f) {
    out.edges.emplace_back(local(e.first), local(e.second));
    out.keys.insert(edgeKey(out.edges.back().first, out.edges.back().second));
  }
  return out;
}

/// Every triangle kFinal or kOpen by stream_frontier.h's test; each label is written by one worker.
std::vector<unsigned char> labelFinalOrOpen(const StripPoints& p, const std::vector<index_t>& t, double seam,
                                            const Hull* hull, unsigned threads) {
  const FinalTriangleTest isFinal(seam, hull);
  std::vector<unsigned char> label(t.size() / 3);
  parallelFor(label.size(), workerCount(label.size(), threads, 16384),
              [&](std::size_t b, std::size_t e, unsigned) {
                for (std::size_t k = b; k < e; ++k) {
                  const index_t u = t[3 * k], v = t[3 * k + 1], w = t[3 * k + 2];
                  label[k] = isFinal(p.x[u], p.y[u], p.x[v], p.y[v], p.x[w], p.y[w]) ? kFinal : kOpen;
                }
              });
  return label;
}

/// Labels kUnderFinal the triangles reached from the final side of a frontier edge without crossing
/// one: they re-triangulate the region the final triangles already cover, so their vertices are
/// resident points (the index covers them).
void labelUnderFinal(const std::vector<index_t>& t, const EdgeIndex& edges, const LocalFrontier& old,
                     std::vector<unsigned char>& label) {
  std::vector<index_t> stack;
  for (const auto& e : old.edges) {
    const index_t f = edges.find(e.first, e.second);
    if (f != kNoTriangle && label[f] != kUnderFinal) label[f] = kUnderFinal, stack.push_back(f);
  }
  while (!stack.empty()) {
    const index_t f = stack.back();
    stack.pop_back();
    for (int j = 0; j < 3; ++j) {
      const index_t p = t[3 * f + j], q = t[3 * f + (j + 1) % 3];
      if (old.has(p, q)) continue;
      const index_t g = edges.find(q, p);
      if (g != kNoTriangle && label[g] != kUnderFinal) label[g] = kUnderFinal, stack.push_back(g);
    }
  }
}

/// The vertices the step asks edges about: the resident points, the vertices of triangles the test
/// leaves open, and the points on the hull's boundary.
std::vector<char> coveredVertices(std::size_t n, const std::vector<index_t>& t,
                                  const std::vector<unsigned char>& label,
                                  const std::vector<index_t>& resident_at,
                                  const std::vector<index_t>& hull_points, unsigned threads) {
  std::vector<char> covered(n, 0);
  for (const index_t v : resident_at) covered[v] = 1;
  for (const index_t v : gatherTriangles(
           t, [&](std::size_t k) { return label[k] == kOpen; }, threads))
    covered[v] = 1;
  for (const index_t v : hull_points) covered[v] = 1;
  return covered;
}

/// The lexicographically smallest (x, then y) of the hull's boundary points that are vertices of a
/// triangle: a vertex of the triangulation's convex hull.
index_t lowestVertex(const StripPoints& p, const std::vector<index_t>& hull_points, const EdgeIndex& edges) {
  index_t lowest = kNoTriangle;
  for (const index_t v : hull_points)
    if (edges.hasTriangles(v) &&
        (lowest == kNoTriangle || p.x[v] < p.x[lowest] || (p.x[v] == p.x[lowest] && p.y[v] < p.y[lowest])))
      lowest = v;
  if (lowest == kNoTriangle) throw Error("dw::dem: internal consistency failure (no hull vertex)");
  return lowest;
}

}  // namespace

void StreamTin::keepDistinct(StripPoints& pts, const tin::TinResult& tin) {
  std::vector<char> dup(pts.size(), 0);
  for (const auto& d : tin.duplicates) dup[d.first] = 1;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (!dup[i]) keepPoint(pts, i);
}

void StreamTin::keepPoint(const StripPoints& pts, std::size_t i) {
  resident_.x.push_back(pts.x[i]), resident_.y.push_back(pts.y[i]);
  resident_.value.push_back(pts.value[i]), resident_.index.push_back(pts.index[i]);
}

void StreamTin::addStrip(StripPoints&& strip, double seam, const FinalTriangles& emit) {
  Clock::time_point clock = Clock::now();
  std::vector<index_t> resident_at;
  StripPoints pts = mergeByIndex(resident_, strip, resident_at, threads_);
  const std::size_t n = pts.size();
  times_.merge_s += since(clock);
  if (n == 0) return;
  tin::TinOptions to;
  to.num_threads = threads_;
  const tin::TinResult tin = tin::triangulate(pts.x.data(), pts.y.data(), n, to);
  times_.tin_s += since(clock);
  if (tin.degenerate) return keepDistinct(pts, tin);  // collinear so far: every distinct point stays
  const std::vector<index_t>& t = tin.triangles;
  std::vector<unsigned char> label = labelFinalOrOpen(pts, t, seam, hull_, threads_);
  const std::vector<index_t> hull_points = hullBoundaryPoints(pts.x.data(), pts.y.data(), n, threads_);
  const EdgeIndex edges(t, coveredVertices(n, t, label, resident_at, hull_points, threads_), threads_);
  const LocalFrontier old = localFrontier(pts, frontier_);
  labelUnderFinal(t, edges, old, label);
  const std::vector<index_t> fin = gatherTriangles(
      t, [&](std::size_t k) { return label[k] == kFinal; }, threads_);
  const std::vector<index_t> open = gatherTriangles(
      t, [&](std::size_t k) { return label[k] == kOpen; }, threads_);
  times_.classify_s += since(clock);
  if (emit && !fin.empty()) emit(pts, fin);
  times_.emit_s += since(clock);

  // The new frontier: old frontier edges and final triangles' edges whose other side is not final.
  std::vector<char> keep(n, 0);
  for (const index_t v : open) keep[v] = 1;
  auto isFrontier = [&](index_t a, index_t b) {
    const index_t across = edges.find(b, a);
    if (across != kNoTriangle) return label[across] == kOpen;
    if (old.has(b, a)) return false;
    // A hull edge: stays on the frontier while a later point may come outside it.
    return laterPointsMayLieRightOf(pts.x[a], pts.y[a], pts.x[b], pts.y[b], seam, hull_);
  };
  // An edge of a final triangle with an open triangle across has two vertices of open triangles; one
  // with none across is a boundary edge. Only such edges need the look-up.
  std::vector<char> boundary(n, 0);
  edges.markBoundary(lowestVertex(pts, hull_points, edges), boundary);
  auto mayBeFrontier = [&](index_t a, index_t b) {
    return (keep[a] && keep[b]) || (boundary[a] && boundary[b]);
  };
  std::vector<std::pair<index_t, index_t>> found;
  for (const auto& e : old.edges)
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
    if (keep[i]) keepPoint(pts, i);
  times_.frontier_s += since(clock);
}

}  // namespace detail
}  // namespace dem
}  // namespace dw
