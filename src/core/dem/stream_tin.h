/// \file stream_tin.h
/// \brief The streaming TIN (internal; docs/dem.md "Beyond memory"): strips of points arrive from north
/// to south; each is triangulated together with the resident points, the triangles that no later point
/// can change (stream_frontier.h) are handed on, and only the points the open part still needs stay.
///
/// Why it is exact. Let F be the final triangles handed on so far (triangles of the whole cloud's
/// Delaunay triangulation), P the points read, R the resident points and S the new strip. Every
/// triangle of DT(P u S) not in F has all its vertices in R u S when R holds the vertices of the open
/// triangles and the endpoints of every hull edge a later point may lie outside of (the strip merge's
/// argument, src/core/tin/strip_merge.h, with the open hull edges in the role of its ghosts). Those
/// triangles have empty circles, so they are triangles of DT(R u S), which also holds triangles inside
/// the region F covers. The frontier (the edges of F whose other side is not in F) bounds that region;
/// flooding DT(R u S) from the F side of each frontier edge without crossing one removes exactly those.
/// Ranks are the global input indices, kept in ascending order in the local arrays, so the symbolic
/// perturbation decides ties as the in-memory TIN does.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/dem/stream_frontier.h"
#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace dw {
namespace dem {
namespace detail {

/// Points of one strip or of the resident set, in ascending global index.
struct StripPoints {
  std::vector<double> x, y, value;
  std::vector<std::uint64_t> index;  ///< global input index (the tie-breaking rank)
  std::size_t size() const { return x.size(); }
  void clear() { x.clear(), y.clear(), value.clear(), index.clear(); }
};

/// Final triangles in indices of `points` (counter-clockwise); `points` is in ascending global index.
using FinalTriangles = std::function<void(const StripPoints& points, const std::vector<index_t>& triangles)>;

/// Wall seconds of addStrip's steps, summed over the strips (where a strip's time goes).
struct StreamTinTimes {
  double merge_s = 0;     ///< the resident points merged into the strip by index
  double tin_s = 0;       ///< the strip's TIN
  double classify_s = 0;  ///< the edge index, the triangles under the final region, final or open
  double emit_s = 0;      ///< the final triangles' consumer (the raster, the mesh)
  double frontier_s = 0;  ///< the new frontier and the resident copy
};

class StreamTin {
 public:
  /// `hull`: the whole cloud's convex hull (may be null: then only the circle test decides).
  StreamTin(const Hull* hull, unsigned threads) : hull_(hull), threads_(threads) {}

  /// Adds the next strip (every point north of all later ones: later points have y < seam; the last
  /// strip passes seam = -HUGE_VAL) and hands the triangles that became final to `emit`.
  void addStrip(StripPoints&& strip, double seam, const FinalTriangles& emit);

  std::size_t residentPoints() const { return resident_.size(); }
  std::size_t frontierEdges() const { return frontier_.size(); }
  const StreamTinTimes& times() const { return times_; }

 private:
  void keepDistinct(StripPoints& pts, const tin::TinResult& tin);
  void keepPoint(const StripPoints& pts, std::size_t i);
  const Hull* hull_;
  unsigned threads_;
  StreamTinTimes times_;
  StripPoints resident_;
  /// Directed edges (global indices) of final triangles, as oriented in them, whose other side is not
  /// final: an open triangle or the outside of an open hull edge.
  std::vector<std::pair<std::uint64_t, std::uint64_t>> frontier_;
};

}  // namespace detail
}  // namespace dem
}  // namespace dw
