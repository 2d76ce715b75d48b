/// \file certificate.h
/// \brief Independent certificate that a triangle list is the Delaunay triangulation of its points:
/// a valid triangulation of the convex hull (orientation, edge manifoldness, convex hull cycle, Euler
/// count) whose every interior edge is locally Delaunay under the exact, symbolically perturbed
/// incircle. Local Delaunay everywhere implies global Delaunay (Delaunay's lemma).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace tin {

struct Certificate {
  bool ok = false;
  std::string message;  ///< the first violation found, or "ok"
  std::size_t triangles = 0, vertices = 0, interior_edges = 0, hull_edges = 0;
};

/// Checks `triangles` (input-index triples) over points (x[i], y[i]). `expected_vertices` (if non-zero)
/// is the number of distinct points that must all be vertices. Ranks for the tie-break are the input
/// indices, as in dw::tin::triangulate. Does not throw on a bad mesh: it reports.
Certificate certifyDelaunay(const double* x, const double* y, std::size_t n, const index_t* triangles,
                            std::size_t num_indices, std::size_t expected_vertices = 0);

/// Convenience overload for any contiguous container of index_t (std::vector<index_t>, ...).
template <typename Container>
Certificate certifyDelaunay(const double* x, const double* y, std::size_t n, const Container& triangles,
                            std::size_t expected_vertices = 0) {
  return certifyDelaunay(x, y, n, triangles.data(), triangles.size(), expected_vertices);
}

}  // namespace tin
}  // namespace dw
