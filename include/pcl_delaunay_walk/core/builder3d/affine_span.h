/// \file affine_span.h
/// \brief Exact test of whether a set of points spans 3D (the precondition of a 3D triangulation), used
/// where the set changes: vertex removal and the sliding-window graph.
#pragma once

#include <cstddef>

#include "pcl_delaunay_walk/core/types.h"

namespace dw {
namespace builder3d {

/// Whether points[ids[0..n)] span 3D, decided with exact predicates. If so and `tetrahedron` is not
/// null, it receives four of the ids that are not coplanar. O(n); repeated points are allowed.
bool spans3D(const Vec3f* points, const index_t* ids, std::size_t n, index_t* tetrahedron = nullptr);

}  // namespace builder3d
}  // namespace dw
