/// \file affine_span.h
/// \brief The affine dimension of a point set, in its two forms:
///  - affineSpan / spans3D: EXACT (predicates), the first points found that span; the precondition of a
///    3D triangulation (the kernel's first tetrahedron, vertex removal, the sliding-window graph).
///  - toleranceAffineDimension: within a tolerance relative to the extent, with an in-plane basis; it
///    picks the graph's construction (a chain on a line, the planar graph, the 3D one), for which a
///    set flat to below float resolution is flat.
#pragma once

#include <cstddef>
#include <vector>

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

/// Affine dimension (0..3) of p within rel_tol times its extent and, for dimension 2, an orthonormal
/// in-plane basis in basis[0..5]; for dimension 1, the line direction in basis[0..2]. Below 1e-9 the
/// off-plane part of a distance is under float resolution for any query, so the lower-dimensional
/// graph is exact (distance^2 = in-plane^2 + off-plane^2).
int toleranceAffineDimension(const std::vector<Vec3f>& p, double basis[6], double rel_tol = 1e-9);

}  // namespace dw
