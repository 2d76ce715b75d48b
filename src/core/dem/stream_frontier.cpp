/// \file stream_frontier.cpp
/// \brief Final triangles, the global hull and final rows for the streaming DEM (see stream_frontier.h).
#include "core/dem/stream_frontier.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "core/dem/ownership.h"
#include "core/tin/circumdisk_side.h"
#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace dem {
namespace detail {

namespace {

/// The part of convex polygon h with y <= seam (Sutherland-Hodgman against one half-plane).
Hull clipBelow(const Hull& h, double seam) {
  Hull out;
  const std::size_t m = h.x.size();
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t j = (i + 1) % m;
    const bool in_i = h.y[i] <= seam, in_j = h.y[j] <= seam;
    if (in_i) out.x.push_back(h.x[i]), out.y.push_back(h.y[i]);
    if (in_i != in_j) {
      const double t = (seam - h.y[i]) / (h.y[j] - h.y[i]);
      out.x.push_back(h.x[i] + t * (h.x[j] - h.x[i]));
      out.y.push_back(seam);
    }
  }
  return out;
}

/// Distance from p to the convex polygon (0 inside or on it; +inf for an empty polygon).
double distanceTo(const Hull& h, double px, double py) {
  const std::size_t m = h.x.size();
  if (m == 0) return HUGE_VAL;
  double best = HUGE_VAL;
  bool inside = m >= 3;
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t j = (i + 1) % m;
    const double ex = h.x[j] - h.x[i], ey = h.y[j] - h.y[i], wx = px - h.x[i], wy = py - h.y[i];
    inside = inside && ex * wy - ey * wx >= 0;
    const double len2 = ex * ex + ey * ey;
    const double t = len2 > 0 ? std::min(1.0, std::max(0.0, (wx * ex + wy * ey) / len2)) : 0.0;
    best = std::min(best, std::hypot(wx - t * ex, wy - t * ey));
  }
  return inside ? 0.0 : best;
}

}  // namespace

FinalTriangleTest::FinalTriangleTest(double seam, const Hull* hull)
    : seam_(seam), hull_(hull), below_(hull ? clipBelow(*hull, seam) : Hull()), extent_(std::fabs(seam)) {
  // Every later point lies in the global hull and has y < seam, so in below_.
  for (std::size_t i = 0; i < below_.x.size(); ++i)
    extent_ = std::max({extent_, std::fabs(below_.x[i]), std::fabs(below_.y[i])});
}

bool FinalTriangleTest::operator()(double ax, double ay, double bx, double by, double cx, double cy) const {
  // seam = -inf: the last strip, no point is to come.
  if (seam_ == -HUGE_VAL || tin::detail::circumdiskProvablyOnSide(ax, ay, bx, by, cx, cy, 1, seam_, false))
    return true;
  double ox, oy, r, margin;
  if (!hull_ || !tin::detail::circumcircleWithMargin(ax, ay, bx, by, cx, cy, ox, oy, r, margin)) return false;
  // The clip's new vertices and the distance are rounded too: a relative 1e-9 of the magnitudes
  // covers them many times over.
  const double slack = margin + 1e-9 * (extent_ + std::fabs(ox) + std::fabs(oy) + r);
  return distanceTo(below_, ox, oy) > r + slack;
}

void splitFinalTriangles(const double* x, const double* y, const index_t* t, std::size_t num_indices,
                         double seam, const Hull* hull, std::vector<index_t>& final_out,
                         std::vector<index_t>& open_out, unsigned threads) {
  const FinalTriangleTest isFinal(seam, hull);
  // Blocks of triangles, appended in block order: the output does not depend on the thread count.
  const std::size_t num_tri = num_indices / 3;
  const unsigned workers = workerCount(num_tri, threads, 16384);
  std::vector<std::vector<index_t>> fin(workers), open(workers);
  parallelFor(num_tri, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    for (std::size_t k = 3 * b; k < 3 * e; k += 3) {
      const index_t a = t[k], bb = t[k + 1], c = t[k + 2];
      std::vector<index_t>& out = isFinal(x[a], y[a], x[bb], y[bb], x[c], y[c]) ? fin[w] : open[w];
      out.insert(out.end(), {a, bb, c});
    }
  });
  for (unsigned w = 0; w < workers; ++w) {
    final_out.insert(final_out.end(), fin[w].begin(), fin[w].end());
    open_out.insert(open_out.end(), open[w].begin(), open[w].end());
  }
}

bool laterPointsMayLieRightOf(double ax, double ay, double bx, double by, double seam, const Hull* hull) {
  if (seam == -HUGE_VAL) return false;
  if (!hull) return true;
  const Hull below = clipBelow(*hull, seam);
  const double ex = bx - ax, ey = by - ay;
  const double len = std::hypot(ex, ey);
  for (std::size_t i = 0; i < below.x.size(); ++i) {
    const double wx = below.x[i] - ax, wy = below.y[i] - ay;
    // The clip's vertices are rounded: a relative 1e-9 of the magnitudes is far above that.
    const double slack =
        1e-9 * len * (std::fabs(ax) + std::fabs(ay) + std::fabs(below.x[i]) + std::fabs(below.y[i]) + len);
    if (ex * wy - ey * wx <= slack) return true;
  }
  return false;
}

Hull convexHull(const double* x, const double* y, std::size_t n) {
  std::vector<index_t> order;
  order.reserve(n);
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) order.push_back(index_t(i));
  std::sort(order.begin(), order.end(),
            [&](index_t a, index_t b) { return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]); });
  // Lower chain left to right, then upper chain right to left; pop while not a strict left turn.
  std::vector<index_t> h(2 * order.size() + 1);
  std::size_t k = 0;
  auto push = [&](index_t p, std::size_t floor) {
    while (k >= floor + 2 &&
           pred::orient2d(x[h[k - 2]], y[h[k - 2]], x[h[k - 1]], y[h[k - 1]], x[p], y[p]) <= 0)
      --k;
    h[k++] = p;
  };
  for (index_t p : order) push(p, 0);
  const std::size_t lower = k - (k > 0 ? 1 : 0);
  for (std::size_t i = order.size(); i-- > 0;) push(order[i], lower);
  Hull out;
  const std::size_t m = k > 1 ? k - 1 : k;  // the last vertex repeats the first
  for (std::size_t i = 0; i < m; ++i) {
    if (i > 0 && x[h[i]] == x[h[i - 1]] && y[h[i]] == y[h[i - 1]]) continue;
    out.x.push_back(x[h[i]]);
    out.y.push_back(y[h[i]]);
  }
  return out;
}

Hull extremeOctagon(const double* x, const double* y, std::size_t n, unsigned threads) {
  // Directions d * 45 degrees, counter-clockwise from +x.
  constexpr double h = 0.7071067811865476;
  constexpr double cx[8] = {1, h, 0, -h, -1, -h, 0, h}, cy[8] = {0, h, 1, h, 0, -h, -1, -h};
  auto dot = [&](std::size_t i, int d) { return x[i] * cx[d] + y[i] * cy[d]; };
  const unsigned workers = workerCount(n, threads, 1 << 16);
  std::vector<std::array<std::size_t, 8>> best(workers);
  parallelFor(n, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    best[w].fill(b);
    for (std::size_t i = b; i < e; ++i)
      for (int d = 0; d < 8; ++d)
        if (dot(i, d) > dot(best[w][d], d)) best[w][d] = i;
  });
  Hull out;
  for (int d = 0; d < 8 && n > 0; ++d) {
    std::size_t top = best[0][d];
    for (unsigned w = 1; w < workers; ++w)
      if (dot(best[w][d], d) > dot(top, d)) top = best[w][d];
    if (out.x.empty() || out.x.back() != x[top] || out.y.back() != y[top])
      out.x.push_back(x[top]), out.y.push_back(y[top]);
  }
  while (out.x.size() > 1 && out.x.back() == out.x.front() && out.y.back() == out.y.front())
    out.x.pop_back(), out.y.pop_back();
  return out;
}

bool deepInside(const Hull& h, double px, double py) {
  const std::size_t m = h.x.size();
  if (m < 3) return false;
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t j = (i + 1) % m;
    const double ex = h.x[j] - h.x[i], ey = h.y[j] - h.y[i], wx = px - h.x[i], wy = py - h.y[i];
    const double slack = 1e-9 * (std::fabs(ex) + std::fabs(ey)) *
                         (std::fabs(h.x[i]) + std::fabs(h.y[i]) + std::fabs(px) + std::fabs(py) + 1.0);
    if (!(ex * wy - ey * wx > slack)) return false;
  }
  return true;
}

std::vector<index_t> hullBoundaryPoints(const double* x, const double* y, std::size_t n, unsigned threads) {
  const Hull core = extremeOctagon(x, y, n, threads);
  const unsigned workers = workerCount(n, threads, 1 << 16);
  std::vector<std::vector<index_t>> near(workers);
  parallelFor(n, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    for (std::size_t i = b; i < e; ++i)
      if (!deepInside(core, x[i], y[i])) near[w].push_back(index_t(i));
  });
  std::vector<index_t> order;
  for (const auto& v : near) order.insert(order.end(), v.begin(), v.end());
  std::sort(order.begin(), order.end(),
            [&](index_t a, index_t b) { return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]); });
  // Both chains, popping only right turns: collinear points on a hull edge stay.
  std::vector<index_t> out, h;
  auto chain = [&](auto first, auto last) {
    h.clear();
    for (auto it = first; it != last; ++it) {
      while (h.size() >= 2 && pred::orient2d(x[h[h.size() - 2]], y[h[h.size() - 2]], x[h.back()], y[h.back()],
                                             x[*it], y[*it]) < 0)
        h.pop_back();
      h.push_back(*it);
    }
    out.insert(out.end(), h.begin(), h.end());
  };
  chain(order.begin(), order.end());
  chain(order.rbegin(), order.rend());
  return out;
}

namespace {
bool insideHull(const Hull& h, double px, double py) {
  const std::size_t m = h.x.size();
  if (m < 3) return false;
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t j = (i + 1) % m;
    if (!ownsEdge(h.x[i], h.y[i], h.x[j], h.y[j], px, py)) return false;
  }
  return true;
}
}  // namespace

void markFinalCells(const RasterGrid& g, std::size_t row_begin, std::size_t row_end,
                    const unsigned char* owned, const Hull& hull, unsigned char* final) {
  for (std::size_t r = row_begin; r < row_end; ++r) {
    const std::size_t base = (r - row_begin) * g.cols;
    const double py = g.centreY(r);
    for (std::size_t c = 0; c < g.cols; ++c)
      final[base + c] = owned[base + c] || !insideHull(hull, g.centreX(c), py) ? 1 : 0;
  }
}

std::size_t leadingFinalRows(const RasterGrid& g, std::size_t row_begin, std::size_t row_end,
                             const unsigned char* owned, const Hull& hull) {
  for (std::size_t r = row_begin; r < row_end; ++r) {
    const unsigned char* row = owned + (r - row_begin) * g.cols;
    const double py = g.centreY(r);
    for (std::size_t c = 0; c < g.cols; ++c)
      if (!row[c] && insideHull(hull, g.centreX(c), py)) return r - row_begin;
  }
  return row_end - row_begin;
}

}  // namespace detail
}  // namespace dem
}  // namespace dw
