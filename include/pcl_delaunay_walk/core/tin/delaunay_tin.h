/// \file delaunay_tin.h
/// \brief Parallel 2D Delaunay triangulation (TIN) of large point sets (seed: Song, Li, Liu): equal-count
/// strips along the long axis (map), Bowyer-Watson per strip in parallel, adjacent strips merged
/// pairwise as soon as both are done (reduce). The result is exactly the Delaunay triangulation of the
/// distinct input points under exact predicates, with cocircular ties broken by a symbolic perturbation
/// ranked by input index, so it does not depend on the number of threads or strips.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace tin {

/// Progress callback: stage name and fraction done in [0, 1]; may be called from worker threads
/// (serialised by the library).
using TinProgress = std::function<void(const std::string& stage, double fraction)>;

struct TinOptions {
  unsigned num_threads = 0;  ///< 0: hardware concurrency
  /// 0: automatic (one below 200k points; else about 1M points per strip, at least two per thread, a
  /// multiple of the thread count); 1: the sequential kernel. The triangles do not depend on it.
  unsigned num_strips = 0;
  TinProgress progress;  ///< optional
};

/// Timings and sizes of one run (seconds; for benchmarks and the app).
struct TinStats {
  /// Wall times of the stages. Merges overlap the strips (a strip is merged with a finished neighbour
  /// as soon as it is done): strips_s ends with the last strip, merge_s is the merging left after it.
  double prepare_s = 0, strips_s = 0, merge_s = 0, output_s = 0;
  double merge_work_s = 0;       ///< all merges' times added up (their total work, overlapped or not)
  std::size_t strips = 0;        ///< strips actually used (non-empty)
  std::size_t merge_points = 0;  ///< points re-triangulated in all merge bands together
  double strip_max_s = 0;        ///< the longest single strip (sort + kernel): the strips' critical path
  double fill_wait_s = 0;        ///< longest wait of a strip for the output array's zero fill (helper thread)
};

struct TinResult {
  /// Triangles as input-index triples, counter-clockwise in (x, y). Duplicated points appear only as
  /// their representative (the smallest input index among the copies).
  std::vector<index_t> triangles;
  /// (duplicate input index, representative input index) for every collapsed duplicate.
  std::vector<std::pair<index_t, index_t>> duplicates;
  /// Input indices skipped because x or y was NaN or infinite.
  std::vector<index_t> skipped;
  std::size_t num_vertices = 0;  ///< distinct finite points
  /// True when the distinct points are collinear (or fewer than 3): no triangle exists.
  bool degenerate = false;
  TinStats stats;

  std::size_t numTriangles() const { return triangles.size() / 3; }
};

/// Delaunay triangulation of the points (x[i], y[i]), i < n. Any n (0 included), duplicates, collinear
/// and cocircular sets are handled; NaN/Inf points are skipped. Coordinates are used as given: callers
/// with georeferenced data should pass them in a centred frame (or LAS integer units) so the
/// floating-point filter succeeds and the exact stage stays rare.
/// Throws dw::Error above 600 million points, when a finite coordinate is outside the range the exact
/// predicates support (0 or 2^-150 <= |v| <= 2^200, see predicates_2d.h), or on an internal consistency
/// failure (never silently wrong).
TinResult triangulate(const double* x, const double* y, std::size_t n, const TinOptions& options = {});

/// The same, taking ownership of the coordinate arrays so peak memory stays lower on huge inputs.
TinResult triangulate(std::vector<double>&& x, std::vector<double>&& y, const TinOptions& options = {});

}  // namespace tin
}  // namespace dw
