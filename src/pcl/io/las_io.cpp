// Explicit instantiations of pcl::io::loadLASFile for PCL's xyz point types.
#include "pcl_delaunay_walk/io/impl/las_io.hpp"

#include <pcl/point_types.h>

#include <pcl/impl/instantiate.hpp>

PCL_INSTANTIATE(loadLASFile, PCL_XYZ_POINT_TYPES)
