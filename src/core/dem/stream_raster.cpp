/// \file stream_raster.cpp
/// \brief Rows held until final, then written in order (see stream_raster.h).
#include "core/dem/stream_raster.h"

#include <algorithm>
#include <cmath>

#include "core/dem/owned_cells.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace dem {
namespace detail {

StreamRaster::StreamRaster(const RasterGrid& grid, const Hull& hull, double max_edge, double nodata,
                           RowSink sink, unsigned threads)
    : grid_(grid),
      hull_(hull),
      max_edge_(max_edge),
      nodata_(nodata),
      sink_(std::move(sink)),
      threads_(threads) {}

void StreamRaster::hold(std::size_t rows) {
  rows = std::min(rows, grid_.rows - next_);
  if (rows <= held_) return;
  values_.resize(rows * grid_.cols, nodata_);
  owned_.resize(rows * grid_.cols, 0);
  held_ = rows;
}

void StreamRaster::add(const StripPoints& p, const std::vector<index_t>& t) {
  if (t.empty() || next_ == grid_.rows) return;
  // The southernmost row a triangle may own a centre of (one row of slack; ownership decides exactly).
  const unsigned workers = workerCount(t.size(), threads_, 1 << 16);
  std::vector<double> low(workers, HUGE_VAL);
  parallelFor(t.size(), workers, [&](std::size_t b, std::size_t e, unsigned w) {
    for (std::size_t k = b; k < e; ++k) low[w] = std::min(low[w], p.y[t[k]]);
  });
  const double ymin = *std::min_element(low.begin(), low.end());
  const double below = std::floor((grid_.north - ymin) / grid_.cell) + 2;
  const std::size_t last = below <= double(next_) ? next_ : std::size_t(std::min(double(grid_.rows), below));
  hold(last - next_);
  const TinRasterStats s =
      rasterizeOwnedCells(p.x.data(), p.y.data(), p.value.data(), p.size(), t.data(), t.size(), grid_, next_,
                          next_ + held_, values_.data(), owned_.data(), max_edge_, threads_);
  stats_.cells_set += s.cells_set;
  stats_.triangles_killed += s.triangles_killed;
}

void StreamRaster::flush(bool last) {
  std::size_t ready = leadingFinalRows(grid_, next_, next_ + held_, owned_.data(), hull_);
  // Rows past the held ones are final when no centre of theirs is inside the hull.
  if (ready == held_) {
    const std::vector<unsigned char> none(grid_.cols, 0);
    while (next_ + ready < grid_.rows &&
           leadingFinalRows(grid_, next_ + ready, next_ + ready + 1, none.data(), hull_) == 1) {
      hold(ready + 1);
      ++ready;
    }
  }
  if (ready > 0) {
    sink_(next_, ready, values_.data());
    values_.erase(values_.begin(), values_.begin() + std::ptrdiff_t(ready * grid_.cols));
    owned_.erase(owned_.begin(), owned_.begin() + std::ptrdiff_t(ready * grid_.cols));
    next_ += ready;
    held_ -= ready;
  }
  if (last && next_ != grid_.rows)
    throw Error("dw::dem: internal consistency failure (row " + std::to_string(next_) +
                " not final after the last strip)");
}

}  // namespace detail
}  // namespace dem
}  // namespace dw
