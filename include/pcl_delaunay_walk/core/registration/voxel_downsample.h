/// \file voxel_downsample.h
/// \brief Voxel-grid downsampling of a scan (as pcl::VoxelGrid: one centroid per occupied voxel).
#pragma once

#include <cstddef>
#include <vector>

#include "pcl_delaunay_walk/core/graph/point_view.h"

namespace dw {

/// The centroid of the finite points in each occupied voxel of edge `leaf` (cubes aligned at the
/// origin), 3 floats per voxel in ascending voxel order, so equal inputs give equal outputs. A leaf
/// <= 0 copies the finite points unchanged. Points so far out that their voxel index passes 2^62 are
/// dropped like non-finite ones; nothing throws.
std::vector<float> voxelDownsample(const PointView& points, double leaf);

}  // namespace dw
