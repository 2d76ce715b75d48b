#include "pcl_delaunay_walk/core/search/caller_metric_search.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <string>

namespace dw {

namespace {

std::uint64_t nextQueryId() {
  static std::atomic<std::uint64_t> counter{0};
  return ++counter;
}

bool byDistanceThenIndex(const WalkNeighbour& a, const WalkNeighbour& b) {
  return a.sqr_distance < b.sqr_distance || (a.sqr_distance == b.sqr_distance && a.index < b.index);
}

/// Sorts by (distance, index) answers that come in the core's order: its local-frame distances differ
/// from the caller's only by rounding, so entries are at most a few places out of order and an
/// insertion sort is about linear (std::sort on the k + 1 answers of a kNN query cost ~10 % of it).
/// Should many entries be far out of place (thousands of duplicates whose caller coordinates
/// differ), it hands over to std::sort once the moves exceed a few per entry.
void sortNearlySorted(std::vector<WalkNeighbour>& out) {
  std::size_t moves = 0;
  const std::size_t budget = 8 * out.size() + 64;
  for (std::size_t i = 1; i < out.size(); ++i) {
    const WalkNeighbour c = out[i];
    std::size_t j = i;
    for (; j > 0 && byDistanceThenIndex(c, out[j - 1]); --j) out[j] = out[j - 1];
    out[j] = c;
    moves += i - j;
    if (moves > budget) {
      std::sort(out.begin(), out.end(), byDistanceThenIndex);
      return;
    }
  }
}

/// Per-thread buffers for the core's answers: steady-state queries allocate nothing.
struct Scratch {
  std::vector<dw::index_t> inputs;
  std::vector<float> dist2;
  std::vector<dw::VertexNeighbour> vertices;
  static Scratch& get() {
    thread_local Scratch s;
    return s;
  }
};

}  // namespace

CallerMetricSearch::CallerMetricSearch(dw::DelaunayGraph::ConstPtr graph, std::vector<float> xyz,
                                       std::vector<std::int32_t> input_to_cloud)
    : xyz_(std::move(xyz)), input_to_cloud_(std::move(input_to_cloud)), id_(nextQueryId()) {
  if (!graph) throw dw::Error("pcl::search::DelaunayWalk: no graph");
  if (xyz_.size() != 3 * graph->numInputPoints())
    throw dw::Error("pcl::search::DelaunayWalk: the graph has " + std::to_string(graph->numInputPoints()) +
                    " input points but the cloud has " + std::to_string(xyz_.size() / 3));
  if (!input_to_cloud_.empty() && input_to_cloud_.size() != graph->numInputPoints())
    throw dw::Error("pcl::search::DelaunayWalk: index map size does not match the graph");
  num_finite_ = graph->originals.size();
  const std::size_t nv = graph->numVertices();
  vertex_.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const dw::index_t first = graph->originals[graph->originals_offsets[v]];
    const float* p0 = &xyz_[3 * static_cast<std::size_t>(first)];
    VertexRecord& r = vertex_[v];
    std::copy(p0, p0 + 3, r.xyz);
    r.cloud = cloudIndex(first);
    const bool shared = graph->originals_offsets[v + 1] - graph->originals_offsets[v] > 1;
    for (dw::index_t o = graph->originals_offsets[v] + 1; o < graph->originals_offsets[v + 1]; ++o) {
      const dw::index_t in = graph->originals[o];
      const float* p = &xyz_[3 * static_cast<std::size_t>(in)];
      // Value equality: +0 and -0 (common in no-return points) give FLANN the same distance bits.
      if (p[0] != p0[0] || p[1] != p0[1] || p[2] != p0[2]) {
        r.cloud = kMixed;
        break;
      }
      r.cloud = std::min(r.cloud, cloudIndex(in));
    }
    if (shared && r.cloud != kMixed) r.cloud = ~r.cloud;  // duplicates: every nearest query is a tie
  }
  for (const dw::Vec3f& p : graph->points)
    extent_ = std::max({extent_, std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  search_ = std::make_shared<const dw::NeighbourSearch>(std::move(graph));
}

void CallerMetricSearch::checkGraphMatches(const dw::DelaunayGraph& g, const std::vector<float>& xyz) {
  const std::size_t n = xyz.size() / 3;
  if (g.numInputPoints() != n)
    throw dw::Error("pcl::search::DelaunayWalk: the graph was built from " +
                    std::to_string(g.numInputPoints()) + " points but the cloud has " + std::to_string(n));
  for (std::size_t i = 0; i < n; ++i) {
    const float* p = &xyz[3 * i];
    const bool finite = std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
    const dw::index_t v = g.input_to_vertex[i];
    if (!finite) {
      if (v != dw::kInvalidIndex)
        throw dw::Error("pcl::search::DelaunayWalk: the graph has a vertex for non-finite point " +
                        std::to_string(i));
      continue;
    }
    if (v >= g.numVertices())
      throw dw::Error("pcl::search::DelaunayWalk: the graph has no vertex for point " + std::to_string(i));
    // The builder stores toLocal() of each point, so a graph of this cloud matches bit for bit.
    const dw::Vec3f l = g.toLocal(p[0], p[1], p[2]);
    const dw::Vec3f& gv = g.points[v];
    if (l.x != gv.x || l.y != gv.y || l.z != gv.z)
      throw dw::Error("pcl::search::DelaunayWalk: the graph was built from other points (point " +
                      std::to_string(i) + " differs)");
  }
}

float CallerMetricSearch::tolerance(float d2, float q_extent) const {
  // Local and caller coordinates each carry a relative rounding of 2^-24 of their magnitude M, so the
  // two squared distances differ by at most ~3.5*2^-23*M*d + ~2^-21*d^2 (+ a tiny M^2 term). The
  // constants below are 2-4x that, so a certified answer is certain; a loose bound only costs a
  // widened query now and then.
  if (!(d2 < std::numeric_limits<float>::infinity())) return std::numeric_limits<float>::infinity();
  const float m = std::max(extent_, q_extent);
  const float d = std::sqrt(std::max(d2, 0.f));
  return 0x1p-21f * (4.f * m * d + 2.f * d2) + 0x1p-44f * m * m + std::numeric_limits<float>::denorm_min();
}

bool CallerMetricSearch::locate(const float q[3], dw::StartStrategy strategy, dw::index_t hint, dw::Vec3f& ql,
                                float& q_extent, dw::WalkResult& nn, CallerMetricSearchStats* stats) const {
  if (num_finite_ == 0 || !std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) return false;
  ql = search_->graph().toLocal(q[0], q[1], q[2]);
  q_extent = std::max({std::fabs(ql.x), std::fabs(ql.y), std::fabs(ql.z)});
  // The answer's caller-side record (vertex_) is read right after the walk, and with queries in no
  // spatial order it is a cache miss that the walk cannot hide (most of nearest()'s own time in a
  // profile). The walk mostly ends at or next to its start, so loading the start's record now
  // overlaps that miss with the walk; each vertex the walk moves to gets its record loaded the same way
  // while its neighbourhood is scanned.
  const dw::index_t start = search_->startVertex(ql, strategy, hint);
  if (start < vertex_.size()) __builtin_prefetch(&vertex_[start]);
  const VertexRecord* const records = vertex_.data();
  nn = dw::walk(search_->graph(), ql, start, [records](dw::index_t j) { __builtin_prefetch(records + j); });
  if (nn.vertex == dw::kInvalidIndex) return false;
  if (stats) {
    stats->nn_vertex = nn.vertex;
    stats->walk_steps = nn.steps;
    stats->widened = false;
    stats->tied = false;
  }
  return true;
}

void CallerMetricSearch::collect(const float q[3], const std::vector<dw::index_t>& inputs, std::size_t count,
                                 std::vector<WalkNeighbour>& out) const {
  out.clear();
  for (std::size_t i = 0; i < count; ++i)
    out.push_back({callerDistance(q, inputs[i]), cloudIndex(inputs[i])});
}

void CallerMetricSearch::collectVertices(const float q[3], const std::vector<dw::VertexNeighbour>& vertices,
                                         std::size_t count, std::vector<WalkNeighbour>& out) const {
  // Sized once and written through a pointer, as radius(): no capacity check per neighbour.
  out.resize(count);
  WalkNeighbour* w = out.data();
  WalkNeighbour* const end = w + count;
  const dw::DelaunayGraph& g = search_->graph();
  for (const dw::VertexNeighbour& vn : vertices) {
    if (w == end) break;
    const VertexRecord& r = vertex_[vn.vertex];
    if (r.cloud != kMixed && vn.inputs == 1) {
      *w++ = {distance(q, r.xyz), r.cloud};
      continue;
    }
    const float shared = r.cloud != kMixed ? distance(q, r.xyz) : 0.f;
    for (dw::index_t o = g.originals_offsets[vn.vertex]; o < g.originals_offsets[vn.vertex + 1] && w != end;
         ++o) {
      const dw::index_t in = g.originals[o];
      *w++ = {r.cloud != kMixed ? shared : callerDistance(q, in), cloudIndex(in)};
    }
  }
  out.resize(static_cast<std::size_t>(w - out.data()));
}

bool CallerMetricSearch::nearest(const float q[3], dw::StartStrategy strategy, dw::index_t hint,
                                 WalkNeighbour& out, CallerMetricSearchStats* stats) const {
  dw::Vec3f ql;
  float qe = 0.f;
  dw::WalkResult nn;
  if (!locate(q, strategy, hint, ql, qe, nn, stats)) return false;
  const dw::DelaunayGraph& g = search_->graph();
  // All originals of the nearest vertex share its local distance; pick among them in the caller metric.
  const VertexRecord& vr = vertex_[nn.vertex];
  WalkNeighbour best{distance(q, vr.xyz), vr.cloud};
  // Points at exactly the best distance, the best included (two or more: a tie).
  std::size_t at_best = 1;
  if (vr.cloud < 0 && vr.cloud != kMixed) {
    best.index = ~vr.cloud;
    at_best = 2;
  } else if (vr.cloud == kMixed) {
    best.index = -1;
    for (dw::index_t o = g.originals_offsets[nn.vertex]; o < g.originals_offsets[nn.vertex + 1]; ++o) {
      const WalkNeighbour c{callerDistance(q, g.originals[o]), cloudIndex(g.originals[o])};
      if (best.index < 0 || byDistanceThenIndex(c, best)) best = c;
    }
    at_best = 0;
    for (dw::index_t o = g.originals_offsets[nn.vertex]; o < g.originals_offsets[nn.vertex + 1]; ++o)
      at_best += callerDistance(q, g.originals[o]) == best.sqr_distance ? 1 : 0;
  }
  // The second nearest vertex is a Delaunay neighbour of the nearest (docs/architecture.md, "Why the searches
  // are exact"), so if every neighbour is clearly farther, no other point can be nearer in the caller's
  // metric either.
  const float tol = tolerance(nn.dist2, qe);
  const float bound = nn.dist2 + 2.f * tol;
  // First from the edge records alone (one contiguous read, no neighbour coordinates): with
  // u = q - x_v and c = u.e, d_j^2 - d_v^2 = 4m(m - c). The slack covers the rounding of e, m and c
  // (about 2^-20 m (m + d), taken 8x). Only an inconclusive edge pays for the neighbour's coordinates.
  // Edges come shortest first (sortNeighbourhoods), and c <= |u| ~ dv for every edge, so once an
  // edge clears the test with c replaced by dv (inflated by 2^-16, far above the rounding of c and of
  // dv), every longer one does too (the left side grows as m^2, the slack as 2^-17 m^2): the rest is
  // not read. Near convergence the query sits next to its vertex and the first edge ends the check.
  const dw::Vec3f u = ql - g.points[nn.vertex];
  const float dv = std::sqrt(nn.dist2);
  const float c_max = dv * (1.f + 0x1p-16f);
  auto clears = [&](float m, float c) { return 4.f * m * (m - c) > 2.f * tol + 0x1p-17f * m * (m + dv); };
  // First of all the vertex's safe ball, which the walk has just read: its radius is below every
  // edge's half-length, and the test only gets easier as m grows past c, so if it clears with m = the
  // radius it clears every edge, and the edge records are not read at all (late in ICP the walk stopped
  // inside that ball without reading them either).
  const float ball = g.safe_radius2.empty() ? 0.f : std::sqrt(g.safe_radius2[nn.vertex]);
  const bool in_ball = ball > c_max && clears(ball, c_max);
  bool certain = true;
  for (dw::index_t e = g.offsets[nn.vertex]; !in_ball && e < g.offsets[nn.vertex + 1]; ++e) {
    const dw::EdgeRecord& r = g.edges[e];
    if (clears(r.m, c_max)) break;
    if (clears(r.m, u.x * r.ex + u.y * r.ey + u.z * r.ez)) continue;
    if (!(dw::squaredDistance(ql, g.points[r.j]) > bound)) {
      certain = false;
      break;
    }
  }
  if (!certain) {
    Scratch& s = Scratch::get();
    search_->radius(ql, bound, nn, s.inputs, s.dist2, 0);
    // The band holds the nearest vertex's originals too: count every point afresh.
    at_best = 0;
    for (std::size_t i = 0; i < s.inputs.size(); ++i) {
      const WalkNeighbour c{callerDistance(q, s.inputs[i]), cloudIndex(s.inputs[i])};
      if (byDistanceThenIndex(c, best)) best = c;
    }
    for (std::size_t i = 0; i < s.inputs.size(); ++i)
      at_best += callerDistance(q, s.inputs[i]) == best.sqr_distance ? 1 : 0;
    if (stats) stats->widened = true;
  }
  if (stats) stats->tied = at_best > 1;
  out = best;
  return true;
}

std::size_t CallerMetricSearch::knn(const float q[3], std::size_t k, dw::StartStrategy strategy,
                                    dw::index_t hint, std::vector<WalkNeighbour>& out,
                                    CallerMetricSearchStats* stats) const {
  out.clear();
  k = std::min(k, num_finite_);
  if (k == 0) return 0;
  if (k == 1) {
    WalkNeighbour nb;
    if (!nearest(q, strategy, hint, nb, stats)) return 0;
    out.push_back(nb);
    return 1;
  }
  dw::Vec3f ql;
  float qe = 0.f;
  dw::WalkResult nn;
  if (!locate(q, strategy, hint, ql, qe, nn, stats)) return 0;
  Scratch& s = Scratch::get();
  const std::size_t want = k < num_finite_ ? k + 1 : k;
  // By vertex: the caller coordinates come from vertex_, in the graph's order, next to what the
  // expansion has just read, rather than from the input-ordered cloud (a miss per neighbour).
  const std::size_t found = search_->knnVertices(ql, want, nn, s.vertices);
  if (found >= k + 1) {
    float dk = 0.f, dk1 = 0.f;  // the k-th and (k+1)-th inputs' local distances
    std::size_t seen = 0;
    for (const dw::VertexNeighbour& vn : s.vertices) {
      if (seen < k && seen + vn.inputs >= k) dk = vn.dist2;
      if (seen + vn.inputs > k) {
        dk1 = vn.dist2;
        break;
      }
      seen += vn.inputs;
    }
    const float bound = dk + 2.f * tolerance(dk, qe);
    if (dk1 > bound) {
      collectVertices(q, s.vertices, k, out);
    } else {
      // The k-th and (k+1)-th are within rounding of each other: take everything in the uncertain
      // band and let the caller's metric decide.
      search_->radius(ql, bound, nn, s.inputs, s.dist2, 0);
      collect(q, s.inputs, s.inputs.size(), out);
      if (stats) stats->widened = true;
    }
  } else {
    collectVertices(q, s.vertices, found, out);
  }
  sortNearlySorted(out);
  if (out.size() > k) out.resize(k);
  return out.size();
}

std::size_t CallerMetricSearch::radius(const float q[3], double radius, std::size_t max_nn,
                                       dw::StartStrategy strategy, dw::index_t hint,
                                       std::vector<WalkNeighbour>& out,
                                       CallerMetricSearchStats* stats) const {
  out.clear();
  if (!(radius >= 0.0)) return 0;
  dw::Vec3f ql;
  float qe = 0.f;
  dw::WalkResult nn;
  if (!locate(q, strategy, hint, ql, qe, nn, stats)) return 0;
  const float r2 = static_cast<float>(radius * radius);  // as FLANN rounds it
  const float bound = r2 + tolerance(r2, qe);
  const std::size_t limit = (max_nn == 0 || max_nn >= num_finite_) ? 0 : max_nn;
  Scratch& s = Scratch::get();
  auto keepInside = [&](std::size_t count) {
    out.clear();
    for (std::size_t i = 0; i < count; ++i) {
      const float d = callerDistance(q, s.inputs[i]);
      if (d < r2) out.push_back({d, cloudIndex(s.inputs[i])});  // strict, as FLANN's radius result set
    }
  };
  if (limit == 0) {
    // By vertex, as knn(): caller coordinates from vertex_, in graph order.
    // Sized once to every input found and written through a pointer: a push_back per point (its
    // capacity check and call) was a visible share of the query in a profile.
    out.resize(search_->radiusVertices(ql, bound, nn, s.vertices));
    WalkNeighbour* w = out.data();
    const dw::DelaunayGraph& g = search_->graph();
    for (const dw::VertexNeighbour& vn : s.vertices) {
      const VertexRecord& rec = vertex_[vn.vertex];
      if (rec.cloud != kMixed && vn.inputs == 1) {
        const float d = distance(q, rec.xyz);
        *w = {d, rec.cloud};
        w += d < r2 ? 1 : 0;  // strict, as FLANN's radius result set
        continue;
      }
      for (dw::index_t o = g.originals_offsets[vn.vertex]; o < g.originals_offsets[vn.vertex + 1]; ++o) {
        const dw::index_t in = g.originals[o];
        const float d = rec.cloud != kMixed ? distance(q, rec.xyz) : callerDistance(q, in);
        if (d < r2) *w++ = {d, cloudIndex(in)};
      }
    }
    out.resize(static_cast<std::size_t>(w - out.data()));
  } else {
    search_->radius(ql, bound, nn, s.inputs, s.dist2, limit + 1);
    if (s.inputs.size() <= limit) {
      keepInside(s.inputs.size());
    } else {
      const float dk = s.dist2[limit - 1];
      const float band = dk + 2.f * tolerance(dk, qe);
      if (s.dist2[limit] > band) {
        keepInside(limit);
      } else {
        search_->radius(ql, std::min(bound, band), nn, s.inputs, s.dist2, 0);
        keepInside(s.inputs.size());
        if (stats) stats->widened = true;
      }
    }
  }
  sortNearlySorted(out);
  if (limit != 0 && out.size() > limit) out.resize(limit);
  return out.size();
}

}  // namespace dw
