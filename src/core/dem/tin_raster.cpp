/// \file tin_raster.cpp
/// \brief TIN-linear rasterisation (see tin_raster.h for the ownership rule that makes it exact).
#include "pcl_delaunay_walk/core/dem/tin_raster.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/dem/owned_cells.h"
#include "core/dem/ownership.h"
#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace dem {

namespace {

/// Candidate cells are found in floating point with this slack (in cells), far above the rounding
/// of a quotient of coordinates; the exact ownership test then decides, so slack costs only tests.
constexpr double kSlack = 1e-6;

struct Corner {
  double x, y;
};

inline bool ownsEdge(const Corner& u, const Corner& v, double px, double py) {
  return detail::ownsEdge(u.x, u.y, v.x, v.y, px, py);
}

/// Inclusive index range [lo, hi] of the centres lo + (k + 0.5) step (k >= 0) in [a, b] along one axis,
/// clipped to [first, last]; empty when lo > hi.
inline void centreRange(double a_cells, double b_cells, std::size_t first, std::size_t last,
                        std::ptrdiff_t& lo, std::ptrdiff_t& hi) {
  const double l = std::ceil(a_cells - 0.5 - kSlack), h = std::floor(b_cells - 0.5 + kSlack);
  lo = l < double(first) ? std::ptrdiff_t(first)
                         : (l > double(last) ? std::ptrdiff_t(last) + 1 : std::ptrdiff_t(l));
  hi = h > double(last) ? std::ptrdiff_t(last)
                        : (h < double(first) ? std::ptrdiff_t(first) - 1 : std::ptrdiff_t(h));
}

/// The x-interval [lo, hi] where the line y = py meets the triangle's edges; false when rounding
/// leaves no edge spanning py or an edge is too close to horizontal for the quotient to be trusted.
inline bool rowSpan(const Corner* t, double py, double& lo, double& hi) {
  lo = HUGE_VAL;
  hi = -HUGE_VAL;
  for (int i = 0; i < 3; ++i) {
    const Corner& u = t[i];
    const Corner& v = t[(i + 1) % 3];
    if (py < std::min(u.y, v.y) || py > std::max(u.y, v.y) || u.y == v.y) continue;
    const double dx = v.x - u.x, dy = v.y - u.y;
    if (std::fabs(dx) > 1e6 * std::fabs(dy)) return false;
    const double x = u.x + (py - u.y) / dy * dx;
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  return lo <= hi;
}

/// One triangle's cells in rows [row_begin, row_end); returns how many it set.
std::size_t rasterizeTriangle(const Corner* t, const double* val, const RasterGrid& g, std::size_t row_begin,
                              std::size_t row_end, double* out, unsigned char* owned = nullptr) {
  const double xmin = std::min({t[0].x, t[1].x, t[2].x}), xmax = std::max({t[0].x, t[1].x, t[2].x});
  const double ymin = std::min({t[0].y, t[1].y, t[2].y}), ymax = std::max({t[0].y, t[1].y, t[2].y});
  std::ptrdiff_t r0, r1, c0, c1;
  centreRange((g.north - ymax) / g.cell, (g.north - ymin) / g.cell, row_begin, row_end - 1, r0, r1);
  if (r0 > r1) return 0;
  centreRange((xmin - g.west) / g.cell, (xmax - g.west) / g.cell, 0, g.cols - 1, c0, c1);
  if (c0 > c1) return 0;
  // Barycentric weights relative to corner 0; the determinant is > 0 (checked exactly by the caller).
  const double bx = t[1].x - t[0].x, by = t[1].y - t[0].y, cx = t[2].x - t[0].x, cy = t[2].y - t[0].y;
  const double inv_det = 1.0 / (bx * cy - by * cx);
  const double db = val ? val[1] - val[0] : 0, dc = val ? val[2] - val[0] : 0;
  std::size_t set = 0;
  for (std::ptrdiff_t r = r0; r <= r1; ++r) {
    const double py = g.centreY(std::size_t(r));
    std::ptrdiff_t a = c0, b = c1;
    double lo, hi;
    if (rowSpan(t, py, lo, hi)) {
      std::ptrdiff_t s0, s1;  // one cell of margin around the floating-point span
      centreRange((lo - g.west) / g.cell - 1, (hi - g.west) / g.cell + 1, 0, g.cols - 1, s0, s1);
      a = std::max(a, s0);
      b = std::min(b, s1);
    }
    double* row = out + (std::size_t(r) - row_begin) * g.cols;
    for (std::ptrdiff_t c = a; c <= b; ++c) {
      const double px = g.centreX(std::size_t(c));
      if (!ownsEdge(t[0], t[1], px, py) || !ownsEdge(t[1], t[2], px, py) || !ownsEdge(t[2], t[0], px, py))
        continue;
      if (owned) {
        owned[(std::size_t(r) - row_begin) * g.cols + std::size_t(c)] = 1;
        if (!val) continue;  // a killed triangle owns its cells but leaves them nodata
      }
      const double ux = px - t[0].x, uy = py - t[0].y;
      const double wb = (ux * cy - uy * cx) * inv_det, wc = (bx * uy - by * ux) * inv_det;
      row[c] = val[0] + wb * db + wc * dc;
      ++set;
    }
  }
  return set;
}

/// A triangle as both rasterisers see it: rotated to start at its smallest vertex index, so the
/// interpolation's rounding does not depend on the rotation the triangulation happened to store, and
/// whether an edge is longer than the kill length. Every cell of every rasteriser comes from here, which
/// is what makes them equal bit for bit.
struct CanonicalTriangle {
  index_t i[3];
  Corner t[3];
  bool killed = false;
};

CanonicalTriangle canonicalTriangle(const index_t* v, const double* x, const double* y, double max_edge2) {
  CanonicalTriangle c;
  const int f = v[0] < v[1] ? (v[0] < v[2] ? 0 : 2) : (v[1] < v[2] ? 1 : 2);
  for (int j = 0; j < 3; ++j) {
    c.i[j] = v[(f + j) % 3];
    c.t[j] = {x[c.i[j]], y[c.i[j]]};
  }
  for (int j = 0; j < 3; ++j) {
    const double dx = c.t[(j + 1) % 3].x - c.t[j].x, dy = c.t[(j + 1) % 3].y - c.t[j].y;
    c.killed = c.killed || dx * dx + dy * dy > max_edge2;
  }
  return c;
}

}  // namespace

TinRasterStats rasterizeTinRows(const double* x, const double* y, const double* value, std::size_t n,
                                const index_t* triangles, std::size_t num_indices, const RasterGrid& grid,
                                std::size_t row_begin, std::size_t row_end, double* out,
                                const TinRasterOptions& options) {
  if (row_begin > row_end || row_end > grid.rows)
    throw Error("rasterizeTinRows: rows [" + std::to_string(row_begin) + ", " + std::to_string(row_end) +
                ") are not inside the grid's " + std::to_string(grid.rows) + " rows");
  if (num_indices % 3 != 0)
    throw Error("rasterizeTinRows: the triangle list's length is not a multiple of 3");
  if (!(grid.cell > 0) || grid.cols == 0) throw Error("rasterizeTinRows: empty grid");
  TinRasterStats total;
  if (row_begin == row_end) return total;
  const std::size_t num_tri = num_indices / 3;
  const unsigned workers = workerCount(num_tri, options.num_threads, 16384);
  // Nodata first, in parallel by rows (so pages are touched by the threads that write them next).
  const std::size_t rows = row_end - row_begin;
  parallelFor(rows, workerCount(rows * grid.cols, options.num_threads, 1 << 16),
              [&](std::size_t b, std::size_t e, unsigned) {
                std::fill(out + b * grid.cols, out + e * grid.cols, options.nodata);
              });
  const double max_edge2 = options.max_edge > 0 ? options.max_edge * options.max_edge : HUGE_VAL;
  std::vector<TinRasterStats> per(workers);
  parallelFor(num_tri, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    TinRasterStats& s = per[w];
    for (std::size_t k = b; k < e; ++k) {
      const index_t* v = triangles + 3 * k;
      if (v[0] >= n || v[1] >= n || v[2] >= n)
        throw Error("rasterizeTinRows: triangle " + std::to_string(k) +
                    " has a vertex index >= " + std::to_string(n));
      const CanonicalTriangle c = canonicalTriangle(v, x, y, max_edge2);
      if (c.killed) {
        ++s.triangles_killed;
        continue;
      }
      const Corner* t = c.t;
      if (pred::orient2d(t[0].x, t[0].y, t[1].x, t[1].y, t[2].x, t[2].y) <= 0) continue;  // not a triangle
      const double val[3] = {value[c.i[0]], value[c.i[1]], value[c.i[2]]};
      s.cells_set += rasterizeTriangle(t, val, grid, row_begin, row_end, out);
      if (w == 0 && options.progress && (k - b) % 65536 == 0) options.progress(double(k - b) / double(e - b));
    }
  });
  for (const auto& s : per) {
    total.cells_set += s.cells_set;
    total.triangles_killed += s.triangles_killed;
  }
  if (options.progress) options.progress(1.0);
  return total;
}

TinRasterStats rasterizeOwnedCells(const double* x, const double* y, const double* value, std::size_t n,
                                   const index_t* triangles, std::size_t num_indices, const RasterGrid& grid,
                                   std::size_t row_begin, std::size_t row_end, double* out,
                                   unsigned char* owned, double max_edge, unsigned threads) {
  TinRasterStats total;
  if (row_begin >= row_end) return total;
  const double max_edge2 = max_edge > 0 ? max_edge * max_edge : HUGE_VAL;
  const std::size_t num_tri = num_indices / 3;
  // Every cell has one owner among triangles of one triangulation, so blocks of triangles write
  // disjoint cells and need no locks; the values do not depend on the split.
  const unsigned workers = workerCount(num_tri, threads, 16384);
  std::vector<TinRasterStats> per(workers);
  parallelFor(num_tri, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    TinRasterStats& s = per[w];
    for (std::size_t k = 3 * b; k < 3 * e; k += 3) {
      const index_t* v = triangles + k;
      if (v[0] >= n || v[1] >= n || v[2] >= n) throw Error("rasterizeOwnedCells: vertex index out of range");
      const CanonicalTriangle c = canonicalTriangle(v, x, y, max_edge2);
      const Corner* t = c.t;
      const bool killed = c.killed;
      const index_t* i = c.i;
      if (pred::orient2d(t[0].x, t[0].y, t[1].x, t[1].y, t[2].x, t[2].y) <= 0) continue;
      const double val[3] = {value[i[0]], value[i[1]], value[i[2]]};
      const std::size_t set =
          rasterizeTriangle(t, killed ? nullptr : val, grid, row_begin, row_end, out, owned);
      if (killed)
        ++s.triangles_killed;
      else
        s.cells_set += set;
    }
  });
  for (const auto& s : per) {
    total.cells_set += s.cells_set;
    total.triangles_killed += s.triangles_killed;
  }
  return total;
}

std::vector<double> rasterizeTin(const double* x, const double* y, const double* value, std::size_t n,
                                 const std::vector<index_t>& triangles, const RasterGrid& grid,
                                 const TinRasterOptions& options, TinRasterStats* stats) {
  std::vector<double> out(grid.size());
  const TinRasterStats s = rasterizeTinRows(x, y, value, n, triangles.data(), triangles.size(), grid, 0,
                                            grid.rows, out.data(), options);
  if (stats) *stats = s;
  return out;
}

}  // namespace dem
}  // namespace dw
