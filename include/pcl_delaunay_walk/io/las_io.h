/// \file las_io.h
/// \brief Loading LAS 1.0-1.4 (point formats 0-10) and LAZ (LASzip-compressed, formats 0-3 and 6-8)
/// into a pcl::PointCloud, with an optional class filter. Georeferenced coordinates do not fit float: the
/// cloud is stored relative to an origin (a point of the LAS integer grid near the data's centre) that is
/// returned in double.
#pragma once

#include <pcl/point_cloud.h>

#include <Eigen/Core>
#include <string>

#include "pcl_delaunay_walk/core/las/las_format.h"

namespace pcl {
namespace io {

/** \brief Options of loadLASFile. */
struct LASLoadOptions {
  int classification = -1;  ///< keep only this class (2 = ground); -1 keeps all
  bool centre = true;       ///< store coordinates relative to a centre of the data (else: world, in float)
};

/** \brief Load a LAS file into a point cloud.
 * Fields filled when PointT has them: x, y, z; intensity (raw 16-bit value); rgb (LAS 16-bit colour
 * scaled to 8 bits); label (classification).
 * \param[in] file_name the .las or .laz file
 * \param[out] cloud the points; world = point + origin
 * \param[out] origin the double-precision origin subtracted from every point (may be nullptr)
 * \param[in] options class filter and centring
 * \return 0 on success; a corrupt or truncated file throws dw::las::LasError naming it (and, for
 * LAZ, the chunk) */
template <typename PointT>
int loadLASFile(const std::string& file_name, pcl::PointCloud<PointT>& cloud,
                Eigen::Vector3d* origin = nullptr, const LASLoadOptions& options = LASLoadOptions());

}  // namespace io
}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include "pcl_delaunay_walk/io/impl/las_io.hpp"
#endif
