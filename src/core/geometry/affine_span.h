/// \file affine_span.h
/// \brief Exact test of whether a set of points spans 3D (the precondition of a 3D triangulation): the
/// kernel's first tetrahedron, vertex removal and the sliding-window graph.
#pragma once

#include <cstddef>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace builder3d {

/// The affine dimension that a scan of points[ids[0..n)] finds, with exact predicates: -1 for no points,
/// 0 if all repeat the first, 1 collinear, 2 coplanar, 3 otherwise. For 3, `positions` (if not null)
/// receives four positions in ids of points that are not coplanar: 0, the first point distinct from
/// the first, the first off their line, the first off their plane (after the second).
int affineSpan(const Vec3f* points, const index_t* ids, std::size_t n, std::size_t positions[4] = nullptr);

/// Whether points[ids[0..n)] span 3D, decided with exact predicates. If so and `tetrahedron` is not
/// null, it receives four of the ids that are not coplanar. O(n); repeated points are allowed.
bool spans3D(const Vec3f* points, const index_t* ids, std::size_t n, index_t* tetrahedron = nullptr);

}  // namespace builder3d
}  // namespace dw
