/// \file stream_raster.h
/// \brief The streaming DEM's raster (internal; docs/dem.md "Beyond memory"): final triangles are
/// rasterised into the rows not yet written as they come, and each leading row whose cells are all
/// final (owned by a final triangle, or outside the whole cloud's hull) goes to the row sink, in order.
/// A written row equals the in-memory raster's row bit for bit (owned_cells.h).
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "core/dem/stream_frontier.h"
#include "core/dem/stream_tin.h"
#include "pcl_delaunay_walk/core/dem/raster_grid.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"

namespace dw {
namespace dem {
namespace detail {

/// Receives rows [row_begin, row_begin + rows), grid.cols values each, in order.
using RowSink = std::function<void(std::size_t row_begin, std::size_t rows, const double* values)>;

class StreamRaster {
 public:
  /// `grid` in the points' frame; `hull` the whole cloud's hull (must outlive this).
  /// `threads`: for rasterising each batch of final triangles (0: all cores).
  StreamRaster(const RasterGrid& grid, const Hull& hull, double max_edge, double nodata, RowSink sink,
               unsigned threads = 1);

  /// Rasterises final triangles (indices into `points`).
  void add(const StripPoints& points, const std::vector<index_t>& triangles);
  /// Writes the leading final rows; `last`: every row must be final now (else an internal error).
  void flush(bool last);

  std::size_t rowsWritten() const { return next_; }
  std::size_t rowsHeld() const { return held_; }
  const TinRasterStats& stats() const { return stats_; }

 private:
  void hold(std::size_t rows);
  RasterGrid grid_;
  const Hull& hull_;
  double max_edge_, nodata_;
  RowSink sink_;
  unsigned threads_;
  std::size_t next_ = 0, held_ = 0;  // rows [next_, next_ + held_) are in the buffers
  std::vector<double> values_;
  std::vector<unsigned char> owned_;
  TinRasterStats stats_;
};

}  // namespace detail
}  // namespace dem
}  // namespace dw
