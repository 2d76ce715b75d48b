/// \file stream_dem.h
/// \brief The streaming DEM (docs/dem.md, "Beyond memory"): LAS/LAZ tiles of one survey read as one
/// cloud, strip by strip from north to south, triangulated and rasterised so that only the strip being
/// read, the open band and the rows not yet final are held. The raster equals the in-memory DEM's
/// (dw_dem without --stream) bit for bit.
///
/// Pass 1 reads every file by chunks (LasReader::read) for the kept points' bounds, their convex hull
/// and a histogram of y, and cuts strips of about the point count the memory limit allows. Pass 2
/// reads the files again and appends each point to its strip's spill file (an unlinked temporary).
/// Then each strip is read back, triangulated with the resident points, its final triangles
/// rasterised, and the final rows handed to the row sink in order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/dem/raster_grid.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"

namespace dw {
namespace dem {

struct StreamDemOptions {
  std::vector<std::string> inputs;  ///< tiles of one survey (same scales, offsets on one integer grid)
  int classification = -1;          ///< keep one class; -1: all
  bool intensity = false;           ///< interpolate intensity instead of z
  double resolution = 1;            ///< cell size, world units
  bool has_bounds = false;          ///< else the aligned grid covering the kept points
  double bounds[4] = {0, 0, 0, 0};  ///< west, south, east, north
  double max_edge = 0, nodata = -9999;
  std::size_t memory_limit_mb = 1024;  ///< sets the strip height (points per strip)
  unsigned threads = 0;
  bool raster = true;  ///< false: no grid and no rows, only the mesh sink (resolution unused)
};

struct StreamDemProgress {
  const char* stage;  ///< "scan", "spill" or "strips"
  std::uint64_t points_read = 0, points_total = 0;
  std::size_t strips_done = 0, strips = 0, rows_written = 0, rows = 0;
  double elapsed_s = 0, rate = 0, left_s = 0;  ///< rate: points per second of the stage
};

struct StreamDemStats {
  std::uint64_t points = 0;  ///< kept points
  std::size_t strips = 0, max_strip_points = 0, max_resident = 0, max_rows_held = 0;
  std::uint64_t triangles = 0;
  TinRasterStats raster;
  double scan_s = 0, spill_s = 0, strips_s = 0;
  /// Where strips_s goes, summed over the strips: reading a strip's spill back, merging the resident
  /// points in, its TIN, sorting final from open triangles, rasterising the final ones (or the mesh
  /// sink), the new frontier and resident set, and handing final rows to the row sink.
  double read_s = 0, merge_s = 0, tin_s = 0, classify_s = 0, emit_s = 0, frontier_s = 0, flush_s = 0;
};

using StreamRowSink = std::function<void(std::size_t row_begin, std::size_t rows, const double* values)>;

/// The streamed TIN itself. `vertex` gets every kept point once, in input order (its global index is
/// the number of calls before it), world x, y, z, during pass 2, before any triangle; `triangles` gets
/// each final triangle of the whole cloud's TIN once, as `count` triples of global indices,
/// counter-clockwise, strip after strip. Duplicate points are vertices that no triangle uses (the
/// in-memory TIN's choice of the one that is used).
struct StreamMeshSink {
  std::function<void(double x, double y, double z)> vertex;
  std::function<void(const std::uint64_t* triangles, std::size_t count)> triangles;
};

class StreamDem {
 public:
  /// Runs pass 1 (throws dw::Error on a bad file, on no kept points, or on tiles on another grid).
  explicit StreamDem(const StreamDemOptions& options,
                     std::function<void(const StreamDemProgress&)> progress = nullptr);
  ~StreamDem();
  /// The raster's grid in world units (the GeoTIFF's); empty without options.raster.
  const RasterGrid& grid() const;
  /// The kept points, known after pass 1 (the streamed mesh's vertex count).
  std::uint64_t points() const;
  /// Pass 2 and the strips; with options.raster every row goes to `sink` once, in order; with `mesh`
  /// its vertices and final triangles go there as described at StreamMeshSink.
  StreamDemStats run(const StreamRowSink& sink, const StreamMeshSink* mesh = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dem
}  // namespace dw
