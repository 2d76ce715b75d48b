// Explicit instantiations of LocalizerDelaunayWalk over the PCL point types with xyz first.
#include "pcl_delaunay_walk/registration/impl/localizer_delaunay_walk.hpp"

#include <pcl/point_types.h>

template class pcl::registration::LocalizerDelaunayWalk<pcl::PointXYZ>;
template class pcl::registration::LocalizerDelaunayWalk<pcl::PointXYZI>;
template class pcl::registration::LocalizerDelaunayWalk<pcl::PointXYZRGB>;
template class pcl::registration::LocalizerDelaunayWalk<pcl::PointNormal>;
template class pcl::registration::LocalizerDelaunayWalk<pcl::PointXYZINormal>;
