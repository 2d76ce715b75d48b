// Explicit instantiations of pcl::search::DelaunayWalk and KdTreeDelaunayWalk for PCL's xyz point types.
#include "pcl_delaunay_walk/search/impl/delaunay_walk.hpp"

#include <pcl/point_types.h>

#include <pcl/impl/instantiate.hpp>

#include "pcl_delaunay_walk/search/impl/kdtree_delaunay_walk.hpp"

PCL_INSTANTIATE(DelaunayWalk, PCL_XYZ_POINT_TYPES)
PCL_INSTANTIATE(KdTreeDelaunayWalk, PCL_XYZ_POINT_TYPES)
