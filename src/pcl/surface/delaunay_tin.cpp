// Explicit instantiations of pcl::DelaunayTin for PCL's xyz point types.
#include "pcl_delaunay_walk/surface/impl/delaunay_tin.hpp"

#include <pcl/point_types.h>

#include <pcl/impl/instantiate.hpp>

PCL_INSTANTIATE(DelaunayTin, PCL_XYZ_POINT_TYPES)
