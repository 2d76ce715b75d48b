#include "pcl_delaunay_walk/core/graph/graph_builder.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

#include "core/geometry/affine_span.h"
#include "core/graph/prepare_vertices.h"
#include "core/util/space_filling_curve.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {

namespace {

void report(const BuildOptions& o, const char* stage, double f) {
  if (o.progress) o.progress(stage, f);
}

/// Vertex sets this small get the complete graph: trivially exact, and it spares the Delaunay
/// builders their degenerate small cases (< 4 points, all coplanar, ...).
constexpr std::size_t kCompleteGraphMax = 8;

EdgeList completeGraph(std::size_t n) {
  EdgeList e;
  for (index_t i = 0; i < n; ++i)
    for (index_t j = i + 1; j < n; ++j) e.emplace_back(i, j);
  return e;
}

EdgeList chainAlongLine(const std::vector<Vec3f>& p, const double dir[3]) {
  // On a line the Voronoi neighbours are the predecessor and successor in order along it. Distinct
  // points may share a position t along the line (they differ off the line by less than the collinearity
  // tolerance): such a group is one "place" on the line, so each member links to every member of its
  // own group and of the neighbouring groups, and the walk can step between any of them.
  std::vector<index_t> order(p.size());
  std::iota(order.begin(), order.end(), index_t(0));
  std::vector<double> t(p.size());
  for (std::size_t i = 0; i < p.size(); ++i)
    t[i] = double(p[i].x) * dir[0] + double(p[i].y) * dir[1] + double(p[i].z) * dir[2];
  std::sort(order.begin(), order.end(), [&](index_t a, index_t b) { return t[a] < t[b]; });
  EdgeList e;
  std::size_t prev_begin = 0, begin = 0;
  while (begin < order.size()) {
    std::size_t end = begin + 1;
    while (end < order.size() && t[order[end]] == t[order[begin]]) ++end;
    for (std::size_t a = begin; a < end; ++a) {
      for (std::size_t b = a + 1; b < end; ++b) e.emplace_back(order[a], order[b]);
      if (begin > 0)
        for (std::size_t b = prev_begin; b < begin; ++b) e.emplace_back(order[a], order[b]);
    }
    prev_begin = begin;
    begin = end;
  }
  return e;
}

/// Delaunay edges of a (nearly) planar vertex set by the project's exact 2D engine (dw::tin), on the
/// points projected onto the plane's orthonormal basis (u then v in `basis`). Off the plane every
/// vertex lies at the same distance within the dimension test's tolerance, so a query's in-plane
/// nearest vertex is its nearest (docs/architecture.md, "Building the graph"). Distinct points whose
/// projections round to one 2D position are linked to each other and share the representative's
/// neighbours, so the walk can step between them. Throws dw::Error where the 2D engine refuses the
/// projected coordinates (outside its exact range).
EdgeList planarDelaunayEdges(const std::vector<Vec3f>& p, const double basis[6], unsigned num_threads) {
  std::vector<double> u(p.size()), v(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double x = p[i].x, y = p[i].y, z = p[i].z;
    u[i] = x * basis[0] + y * basis[1] + z * basis[2];
    v[i] = x * basis[3] + y * basis[4] + z * basis[5];
  }
  tin::TinOptions to;
  to.num_threads = num_threads;
  const tin::TinResult t = tin::triangulate(std::move(u), std::move(v), to);
  if (t.degenerate) throw Error("pcl_delaunay_walk: planar set without a 2D triangle");
  EdgeList e;
  e.reserve(t.triangles.size() + 2 * t.duplicates.size());
  for (std::size_t k = 0; k + 2 < t.triangles.size(); k += 3) {
    const index_t* tri = &t.triangles[k];
    e.emplace_back(tri[0], tri[1]);
    e.emplace_back(tri[1], tri[2]);
    e.emplace_back(tri[2], tri[0]);
  }
  if (!t.duplicates.empty()) {
    std::vector<std::vector<index_t>> copies(p.size());
    for (const auto& d : t.duplicates) copies[d.second].push_back(d.first);
    const std::size_t triangle_edges = e.size();
    for (std::size_t k = 0; k < triangle_edges; ++k)
      for (int side = 0; side < 2; ++side) {
        const index_t rep = side ? e[k].second : e[k].first, other = side ? e[k].first : e[k].second;
        for (index_t c : copies[rep]) e.emplace_back(c, other);
      }
    for (const auto& d : t.duplicates) e.emplace_back(d.first, d.second);
    for (const auto& group : copies)
      for (std::size_t a = 0; a < group.size(); ++a)
        for (std::size_t b = a + 1; b < group.size(); ++b) e.emplace_back(group[a], group[b]);
  }
  return e;
}

/// The planar graph by the 2D engine (Qhull when the caller chose it), or by Qhull where the engine
/// refuses the projection.
EdgeList planarEdges(const std::vector<Vec3f>& p, const double basis[6], const BuildOptions& options) {
  if (options.builder == BuilderType::Qhull) return qhullDelaunayEdges(p, 2, basis);
  try {
    return planarDelaunayEdges(p, basis, options.num_threads);
  } catch (const Error&) {
    if (!haveQhullBuilder()) throw;
    return qhullDelaunayEdges(p, 2, basis);
  }
}

/// The graph's edges by the vertex set's affine dimension: the complete graph of tiny sets, a chain
/// on a line, the planar Delaunay graph on a plane, the 3D one otherwise. Sets `distinct` when every
/// edge is listed once.
EdgeList delaunayEdges(DelaunayGraph& g, const BuildOptions& options, bool& distinct) {
  double basis[6] = {0, 0, 0, 0, 0, 0};
  g.dimension = toleranceAffineDimension(g.points, basis);
  const std::size_t nv = g.points.size();
  distinct = false;
  if (nv <= kCompleteGraphMax) return completeGraph(nv);
  if (g.dimension == 1) return chainAlongLine(g.points, basis);
  if (g.dimension == 2) {
    report(options, "delaunay-2d", 0.0);
    return planarEdges(g.points, basis, options);
  }
  BuilderType b = options.builder;
  if (b == BuilderType::Auto) b = haveIncrementalBuilder() ? BuilderType::Incremental : BuilderType::Qhull;
  report(options, "delaunay-3d", 0.0);
  try {
    if (b == BuilderType::Incremental) {
      distinct = true;  // the incremental builder lists each edge once
      return incrementalDelaunayEdges(g.points, options);
    }
    return qhullDelaunayEdges(g.points, 3, nullptr);
  } catch (const Error&) {
    // Nearly flat sets (a tilted plane rounded to float) can defeat a 3D builder; within 1e-6 of the
    // extent the planar graph errs by less than float resolution on the query distances.
    if (toleranceAffineDimension(g.points, basis, 1e-6) != 2) throw;
    g.dimension = 2;
    distinct = false;
    return planarEdges(g.points, basis, options);
  }
}

}  // namespace

DelaunayGraph buildDelaunayGraph(const PointView& view, const BuildOptions& options) {
  if (view.size > 0 && view.data == nullptr) throw Error("pcl_delaunay_walk: point view without data");
  if (view.size >= static_cast<std::size_t>(kInvalidIndex))
    throw Error("pcl_delaunay_walk: at most 2^32-2 input points are supported");
  DelaunayGraph g;
  report(options, "prepare", 0.0);
  if (!detail::prepareVertices(view, resolveThreads(options.num_threads), g)) return g;
  report(options, "prepare", 1.0);
  bool distinct = false;
  EdgeList edges = delaunayEdges(g, options, distinct);
  report(options, "assemble", 0.0);
  assembleEdges(g, std::move(edges), distinct, options.num_threads);
  report(options, "assemble", 1.0);
  return g;
}

}  // namespace dw
