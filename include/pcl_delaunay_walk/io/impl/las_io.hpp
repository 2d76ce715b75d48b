/// \file las_io.hpp
/// \brief Template definition of pcl::io::loadLASFile.
#pragma once

#include <pcl/point_types.h>

#include <cmath>
#include <limits>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/io/las_io.h"

namespace pcl {
namespace io {

template <typename PointT>
int loadLASFile(const std::string& file_name, pcl::PointCloud<PointT>& cloud, Eigen::Vector3d* origin,
                const LASLoadOptions& options) {
  dw::las::LasReader reader(file_name);
  const dw::las::LasHeader& h = reader.header();
  // First pass over the integer bounds would cost a second read; the header's bounds are enough to
  // pick a centre on the integer grid (a wrong header only makes the floats less centred).
  std::int64_t centre[3] = {0, 0, 0};
  if (options.centre)
    for (int k = 0; k < 3; ++k) {
      const double mid = 0.5 * (h.min[k] + h.max[k]);
      centre[k] = std::isfinite(mid) ? std::llround((mid - h.offset[k]) / h.scale[k]) : 0;
    }
  Eigen::Vector3d o;
  for (int k = 0; k < 3; ++k) o[k] = centre[k] * h.scale[k] + h.offset[k];
  if (!options.centre) o.setZero();
  if (origin) *origin = o;

  cloud.clear();
  if (options.classification < 0) cloud.reserve(h.point_count);
  std::vector<dw::las::LasRecord> chunk;
  while (reader.read(chunk, 1 << 16) > 0) {
    for (const auto& r : chunk) {
      if (options.classification >= 0 && r.classification != options.classification) continue;
      PointT p;
      const std::int32_t v[3] = {r.X, r.Y, r.Z};
      float f[3];
      for (int k = 0; k < 3; ++k)
        // Integer difference first (exact), one rounding to float at the end.
        f[k] = options.centre ? float(double(std::int64_t(v[k]) - centre[k]) * h.scale[k])
                              : float(v[k] * h.scale[k] + h.offset[k]);
      p.x = f[0];
      p.y = f[1];
      p.z = f[2];
      if constexpr (pcl::traits::has_intensity_v<PointT>) p.intensity = float(r.intensity);
      if constexpr (pcl::traits::has_color_v<PointT>) {
        const bool wide = r.rgb[0] > 255 || r.rgb[1] > 255 || r.rgb[2] > 255;
        p.r = std::uint8_t(wide ? r.rgb[0] >> 8 : r.rgb[0]);
        p.g = std::uint8_t(wide ? r.rgb[1] >> 8 : r.rgb[1]);
        p.b = std::uint8_t(wide ? r.rgb[2] >> 8 : r.rgb[2]);
      }
      if constexpr (pcl::traits::has_label_v<PointT>) p.label = r.classification;
      cloud.push_back(p);
    }
  }
  cloud.width = static_cast<std::uint32_t>(cloud.size());
  cloud.height = 1;
  cloud.is_dense = true;
  return 0;
}

}  // namespace io
}  // namespace pcl

#define PCL_INSTANTIATE_loadLASFile(T)                                                            \
  template int pcl::io::loadLASFile<T>(const std::string&, pcl::PointCloud<T>&, Eigen::Vector3d*, \
                                       const pcl::io::LASLoadOptions&);
