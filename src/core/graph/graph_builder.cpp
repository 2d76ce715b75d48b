#include "pcl_delaunay_walk/core/graph/graph_builder.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

#include "core/util/parallel_sort.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "core/util/space_filling_curve.h"
#include "core/geometry/vec3d.h"

namespace dw {

namespace {

void report(const BuildOptions& o, const char* stage, double f) {
  if (o.progress) o.progress(stage, f);
}

/// Vertex sets this small get the complete graph: trivially exact, and it spares the Delaunay
/// builders their degenerate small cases (< 4 points, all coplanar, ...).
constexpr std::size_t kCompleteGraphMax = 8;

/// Largest supported extent along any axis: its square must stay well inside float range.
constexpr double kMaxExtent = 1e18;

/// Affine dimension of the vertex set and, for dim 2, an orthonormal in-plane basis; for dim 1, the
/// line direction in basis[0..2]. Thresholds are relative to the extent; below 1e-9 the off-plane
/// part of a distance is under float resolution for any query, so the lower-dimensional graph is
/// exact (distance^2 = in-plane^2 + off-plane^2, DESIGN.md §2).
int affineDimension(const std::vector<Vec3f>& p, double basis[6], double rel_tol = 1e-9) {
  if (p.empty()) return 0;
  const auto p0 = toVec3d(p[0]);
  std::size_t i1 = 0;
  double best = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto d = sub(toVec3d(p[i]), p0);
    const double l = dot(d, d);
    if (l > best) best = l, i1 = i;
  }
  if (best == 0) return 0;
  const double extent = std::sqrt(best);
  const double tol = rel_tol * extent;
  auto dir = sub(toVec3d(p[i1]), p0);
  for (double& c : dir) c /= extent;
  std::size_t i2 = 0;
  best = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto d = sub(toVec3d(p[i]), p0);
    const auto c = cross(dir, d);
    const double l = dot(c, c);
    if (l > best) best = l, i2 = i;
  }
  basis[0] = dir[0], basis[1] = dir[1], basis[2] = dir[2];
  if (std::sqrt(best) <= tol) return 1;
  auto w = sub(toVec3d(p[i2]), p0);
  const double t = dot(w, dir);
  for (int a = 0; a < 3; ++a) w[a] -= t * dir[a];
  const double wl = std::sqrt(dot(w, w));
  for (double& c : w) c /= wl;
  basis[3] = w[0], basis[4] = w[1], basis[5] = w[2];
  const auto nrm = cross(dir, w);
  double off = 0;
  for (const Vec3f& q : p) off = std::max(off, std::fabs(dot(sub(toVec3d(q), p0), nrm)));
  return off <= tol ? 2 : 3;
}

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

}  // namespace

DelaunayGraph buildDelaunayGraph(const PointView& view, const BuildOptions& options) {
  if (view.size > 0 && view.data == nullptr) throw Error("pcl_delaunay_walk: point view without data");
  if (view.size >= static_cast<std::size_t>(kInvalidIndex))
    throw Error("pcl_delaunay_walk: at most 2^32-2 input points are supported");
  DelaunayGraph g;
  const std::size_t n = view.size;
  g.input_to_vertex.assign(n, kInvalidIndex);
  report(options, "prepare", 0.0);
  // Every step of the preparation runs on the build's threads, in blocks whose results are joined in
  // block order, so the graph is the same for any thread count.
  const unsigned threads = resolveThreads(options.num_threads);
  const unsigned input_workers = workerCount(n, threads, std::size_t(1) << 16);

  // Origin: centre of the finite points' bounding box, in double. Centring is what keeps Qhull correct
  // on georeferenced input, and float storage precise (DESIGN.md §2).
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  std::vector<index_t> finite;
  {
    struct Block {
      std::vector<index_t> finite;
      double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    };
    std::vector<Block> blocks(input_workers);
    parallelFor(n, input_workers, [&](std::size_t b, std::size_t e, unsigned w) {
      Block& block = blocks[w];
      block.finite.reserve(e - b);
      for (std::size_t i = b; i < e; ++i) {
        const auto p = view[i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
        block.finite.push_back(static_cast<index_t>(i));
        for (int a = 0; a < 3; ++a)
          block.lo[a] = std::min(block.lo[a], p[a]), block.hi[a] = std::max(block.hi[a], p[a]);
      }
    });
    std::size_t count = 0;
    for (const Block& block : blocks) count += block.finite.size();
    finite.reserve(count);
    for (Block& block : blocks) {
      finite.insert(finite.end(), block.finite.begin(), block.finite.end());
      detail::freeScratch(block.finite);
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], block.lo[a]), hi[a] = std::max(hi[a], block.hi[a]);
    }
  }
  if (finite.empty()) return g;
  for (int a = 0; a < 3; ++a) {
    g.origin[a] = 0.5 * (lo[a] + hi[a]);
    // Squared distances are float: beyond ~1e18 they overflow. Real clouds span far less.
    if (!(hi[a] - lo[a] <= kMaxExtent))
      throw Error("pcl_delaunay_walk: the finite points span " + std::to_string(hi[a] - lo[a]) +
                  " along an axis; at most 1e18 is supported (float squared distances)");
  }

  // Local float coordinates and Morton keys; one sort by (key, x, y, z, input index) both orders the
  // vertices along the curve and makes exact duplicates adjacent.
  struct Item {
    std::uint64_t key;
    Vec3f p;
    index_t input;
  };
  std::vector<Item> items(finite.size());
  double scale = 0;
  for (int a = 0; a < 3; ++a) scale = std::max(scale, hi[a] - lo[a]);
  const double cell = scale > 0 ? double((1u << 21) - 1) / scale : 0.0;
  parallelFor(finite.size(), workerCount(finite.size(), threads, std::size_t(1) << 16),
              [&](std::size_t b, std::size_t e, unsigned) {
                for (std::size_t k = b; k < e; ++k) {
                  const auto p = view[finite[k]];
                  Item& it = items[k];
                  it.p = g.toLocal(p[0], p[1], p[2]);
                  it.input = finite[k];
                  // The key comes from the float position, so inputs that round to one float position
                  // (and so collapse below) get equal keys and end up adjacent in the sort.
                  const double fp[3] = {double(it.p.x) + g.origin[0], double(it.p.y) + g.origin[1],
                                        double(it.p.z) + g.origin[2]};
                  auto q = [&](int a) {
                    return static_cast<std::uint32_t>(
                        std::clamp((fp[a] - lo[a]) * cell, 0.0, double((1u << 21) - 1)));
                  };
                  it.key = mortonKey(q(0), q(1), q(2));
                }
              });
  // The order is total (the input index breaks the last ties): the same for every thread count. The
  // keys are 63 bits (21 per axis); their top 16 bucket the items first.
  detail::bucketThenSort(
      items, 1u << 16, [](const Item& it) { return static_cast<unsigned>(it.key >> 47); },
      [](const Item& a, const Item& b) {
        if (a.key != b.key) return a.key < b.key;
        if (a.p.x != b.p.x) return a.p.x < b.p.x;
        if (a.p.y != b.p.y) return a.p.y < b.p.y;
        if (a.p.z != b.p.z) return a.p.z < b.p.z;
        return a.input < b.input;
      },
      threads);
  // Exact repeats are adjacent now: each run of equal positions is one vertex, which keeps the run's
  // input indices (ascending) as its originals. Per block: count the vertices that start there; then,
  // from each block's first vertex number, write the vertices, originals and maps.
  const std::size_t m = items.size();
  auto startsVertex = [&](std::size_t k) {
    return k == 0 || items[k].p.x != items[k - 1].p.x || items[k].p.y != items[k - 1].p.y ||
           items[k].p.z != items[k - 1].p.z;
  };
  const unsigned item_workers = workerCount(m, threads, std::size_t(1) << 16);
  std::vector<std::size_t> first_vertex(item_workers + 1, 0);
  parallelFor(m, item_workers, [&](std::size_t b, std::size_t e, unsigned w) {
    std::size_t starts = 0;
    for (std::size_t k = b; k < e; ++k) starts += startsVertex(k);
    first_vertex[w + 1] = starts;
  });
  for (unsigned w = 0; w < item_workers; ++w) first_vertex[w + 1] += first_vertex[w];
  const std::size_t num_vertices = first_vertex[item_workers];
  g.points.resize(num_vertices);
  g.originals.resize(m);
  g.originals_offsets.resize(num_vertices + 1);
  g.originals_offsets[num_vertices] = static_cast<index_t>(m);
  parallelFor(m, item_workers, [&](std::size_t b, std::size_t e, unsigned w) {
    std::size_t v = first_vertex[w];  // the number of the next vertex to start
    for (std::size_t k = b; k < e; ++k) {
      if (startsVertex(k)) {
        g.points[v] = items[k].p;
        g.originals_offsets[v] = static_cast<index_t>(k);
        ++v;
      }
      g.originals[k] = items[k].input;
      g.input_to_vertex[items[k].input] = static_cast<index_t>(v - 1);
    }
  });
  detail::freeScratch(items);
  report(options, "prepare", 1.0);

  double basis[6] = {0, 0, 0, 0, 0, 0};
  g.dimension = affineDimension(g.points, basis);
  const std::size_t nv = g.points.size();
  EdgeList edges;
  bool distinct = false;  // the incremental builder lists each edge once
  if (nv <= kCompleteGraphMax) {
    edges = completeGraph(nv);
  } else if (g.dimension == 1) {
    edges = chainAlongLine(g.points, basis);
  } else if (g.dimension == 2) {
    report(options, "delaunay-2d", 0.0);
    edges = qhullDelaunayEdges(g.points, 2, basis);
  } else {
    BuilderType b = options.builder;
    if (b == BuilderType::Auto) b = haveIncrementalBuilder() ? BuilderType::Incremental : BuilderType::Qhull;
    report(options, "delaunay-3d", 0.0);
    try {
      if (b == BuilderType::Incremental) {
        edges = incrementalDelaunayEdges(g.points, options);
        distinct = true;
      } else {
        edges = qhullDelaunayEdges(g.points, 3, nullptr);
      }
    } catch (const Error&) {
      // Nearly flat sets (a tilted plane rounded to float) can defeat a 3D builder; within 1e-6 of the
      // extent the planar graph errs by less than float resolution on the query distances.
      if (affineDimension(g.points, basis, 1e-6) != 2) throw;
      g.dimension = 2;
      edges = qhullDelaunayEdges(g.points, 2, basis);
    }
  }
  report(options, "assemble", 0.0);
  assembleEdges(g, std::move(edges), distinct, options.num_threads);
  report(options, "assemble", 1.0);
  return g;
}

}  // namespace dw
