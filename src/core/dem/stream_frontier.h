/// \file stream_frontier.h
/// \brief What a strip-by-strip DEM may write before the rest of the cloud is read (internal; the
/// building blocks of the streaming mode, docs/dem.md "Beyond memory"). Strips arrive from north to
/// south, so every point still to come has y < seam.
///
/// A triangle of the points read so far whose closed circumdisk lies north of the seam is *final*: no
/// later point can enter its circle, so it is a triangle of the whole cloud's Delaunay triangulation
/// (the strip merge's "sure" triangles, src/core/tin/strip_merge.h). A cell is final when a final
/// triangle owns its centre, or when the centre lies outside the convex hull of the whole cloud
/// (known from a first pass): no triangle will ever own it. A row of final cells can be rasterised
/// from the final triangles and written; it equals the in-memory raster's row bit for bit.
#pragma once

#include <cstddef>
#include <vector>

#include "pcl_delaunay_walk/core/dem/raster_grid.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace dem {
namespace detail {

/// A convex polygon, counter-clockwise, without repeated or collinear vertices.
struct Hull {
  std::vector<double> x, y;
};

/// The test splitFinalTriangles applies to each triangle, set up once for a seam and a hull (which
/// must outlive it); thread-safe to call.
class FinalTriangleTest {
 public:
  FinalTriangleTest(double seam, const Hull* hull);
  bool operator()(double ax, double ay, double bx, double by, double cx, double cy) const;

 private:
  double seam_;
  const Hull* hull_;
  Hull below_;  // the part of the hull with y <= seam
  double extent_;
};

/// Appends each triangle to `final_out` when its closed circumdisk provably holds no point still to
/// come, else to `open_out`. Those points have y < seam and, when `hull` (the whole cloud's convex
/// hull) is given, lie in it: a disk that crosses the seam is still final when it misses the part of
/// the hull below the seam (the long thin triangles along a straight tile edge have huge circles that
/// bulge out of the hull). Conservative: a doubtful triangle is open, which only delays it.
/// seam = -HUGE_VAL: nothing is to come, every triangle is final. Both outputs keep the input order,
/// for any `threads` (0: all cores).
void splitFinalTriangles(const double* x, const double* y, const index_t* triangles, std::size_t num_indices,
                         double seam, const Hull* hull, std::vector<index_t>& final_out,
                         std::vector<index_t>& open_out, unsigned threads = 1);

/// Whether a point still to come (y < seam, inside `hull` when given) may lie in the closed half-plane
/// right of the directed line a -> b: the outside of a hull edge whose interior is on its left. False
/// means the edge stays a hull edge for ever and no later point connects to it from outside.
/// Conservative (true when in doubt); seam = -HUGE_VAL: false.
bool laterPointsMayLieRightOf(double ax, double ay, double bx, double by, double seam, const Hull* hull);

/// The convex hull of the points (Andrew's monotone chain with the exact orient2d); NaN/Inf skipped.
/// Fewer than three vertices when the points are collinear (then no centre is ever inside).
Hull convexHull(const double* x, const double* y, std::size_t n);

/// The points' extreme points in eight directions (45 degrees apart), counter-clockwise without
/// repeats: a convex polygon inside their hull.
Hull extremeOctagon(const double* x, const double* y, std::size_t n, unsigned threads = 1);

/// Whether (px, py) is inside convex polygon h (counter-clockwise) by a margin far above rounding:
/// then it is inside any hull that contains h and is no point of that hull's boundary.
bool deepInside(const Hull& h, double px, double py);

/// Every point on the boundary of the points' convex hull (vertices and the points on its edges), and
/// possibly a few more, without duplicates removed: a filter by the polygon of the extreme points in
/// eight directions, then a monotone chain that keeps collinear points. Linear work on `threads`
/// threads plus a sort of the points the filter leaves (those near the hull).
std::vector<index_t> hullBoundaryPoints(const double* x, const double* y, std::size_t n, unsigned threads);

/// Marks the final cells of rows [row_begin, row_end): final[i] = 1 where owned[i] != 0 (a final
/// triangle owns the cell, i = (r - row_begin) * grid.cols + c) or the centre is outside `hull` by the
/// ownership rule of tin_raster.h (no triangle ever will own it), else 0.
void markFinalCells(const RasterGrid& grid, std::size_t row_begin, std::size_t row_end,
                    const unsigned char* owned, const Hull& hull, unsigned char* final);

/// The number of leading rows of [row_begin, row_end) whose cells are all final (markFinalCells).
/// Rows near the hull's long straight edges wait longest (their thin triangles' circles stay open for
/// many strips), so a writer of GeoTIFF tiles writes each tile once its own cells are final.
std::size_t leadingFinalRows(const RasterGrid& grid, std::size_t row_begin, std::size_t row_end,
                             const unsigned char* owned, const Hull& hull);

}  // namespace detail
}  // namespace dem
}  // namespace dw
