/// \file synthetic_lidar.h
/// \brief Synthetic airborne LiDAR for large TIN inputs (2M-100M points): smooth terrain with buildings
/// (flat and gabled roofs) and trees (multi-return crowns), sampled by a zig-zag scan-line pattern along
/// parallel flight lines and quantised like LAS (integer units of a scale, large UTM-like offsets).
/// Deterministic for a given seed. Streams records: memory does not grow with the point count.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "pcl_delaunay_walk/core/las/las_format.h"

namespace dw {
namespace las {

struct LidarGenOptions {
  std::uint64_t num_points = 2000000;  ///< records to produce (returns, not pulses)
  double density = 8.0;                ///< pulses per square metre
  double swath = 400.0;                ///< flight-line swath width in metres
  double scale = 0.01;                 ///< LAS scale (x, y, z)
  double offset_x = 500000.0, offset_y = 6000000.0, offset_z = 0.0;
  std::uint64_t seed = 1;
  /// This tile's column and row in a survey of equal tiles (the same options but the tile): tile (c, r)
  /// covers [c W, (c + 1) W] x [r L, (r + 1) L] of the survey's frame, W x L the area `num_points`
  /// needs, with the same scale and offsets, so the tiles are one cloud (dw_dem, dw_tin). The terrain
  /// is continuous across tiles; buildings and trees are drawn per tile (cut at its edges), and tile
  /// (0, 0) is the single tile the same options give without tiling.
  std::uint32_t tile_col = 0, tile_row = 0;
};

/// The LAS header (1.2, format 1; 1.4, format 6 beyond 2^32 points) matching the generated records.
LasHeader syntheticHeader(const LidarGenOptions& options);

/// Calls `emit` once per record, in acquisition order. Classes: 2 ground, 5 high vegetation, 6 building.
void generateLidar(const LidarGenOptions& options, const std::function<void(const LasRecord&)>& emit);

/// Generates straight into a LAS file; returns the number of records written.
std::uint64_t writeSyntheticLas(const std::string& path, const LidarGenOptions& options,
                                const std::function<void(double)>& progress = {});

}  // namespace las
}  // namespace dw
