// Explicit instantiations of IterativeClosestPointDelaunayWalk for same-type pairs of PCL xyz points.
// PCL's own SVD transformation estimation, instantiated here, trips GCC 12 middle-end warnings inside
// Eigen (false positives on unaligned loads); they are not ours to fix, so they are silenced here only.
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#include "pcl_delaunay_walk/registration/impl/icp_delaunay_walk.hpp"

#include <pcl/point_types.h>

#define DW_INSTANTIATE_ICP(T)                                         \
  template class pcl::IterativeClosestPointDelaunayWalk<T, T, float>; \
  template class pcl::IterativeClosestPointDelaunayWalk<T, T, double>;

DW_INSTANTIATE_ICP(pcl::PointXYZ)
DW_INSTANTIATE_ICP(pcl::PointXYZI)
DW_INSTANTIATE_ICP(pcl::PointXYZRGB)
DW_INSTANTIATE_ICP(pcl::PointNormal)
DW_INSTANTIATE_ICP(pcl::PointXYZINormal)
DW_INSTANTIATE_ICP(pcl::PointXYZRGBNormal)
