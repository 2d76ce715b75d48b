// Explicit instantiations of the walk correspondence estimator for same-type pairs of PCL xyz points.
#include "pcl_delaunay_walk/registration/impl/correspondence_estimation_delaunay_walk.hpp"

#include <pcl/point_types.h>

#define DW_INSTANTIATE_CE(T)                                                           \
  template class pcl::registration::CorrespondenceEstimationDelaunayWalk<T, T, float>; \
  template class pcl::registration::CorrespondenceEstimationDelaunayWalk<T, T, double>;

DW_INSTANTIATE_CE(pcl::PointXYZ)
DW_INSTANTIATE_CE(pcl::PointXYZI)
DW_INSTANTIATE_CE(pcl::PointXYZRGB)
DW_INSTANTIATE_CE(pcl::PointXYZRGBA)
DW_INSTANTIATE_CE(pcl::PointNormal)
DW_INSTANTIATE_CE(pcl::PointXYZINormal)
DW_INSTANTIATE_CE(pcl::PointXYZRGBNormal)
