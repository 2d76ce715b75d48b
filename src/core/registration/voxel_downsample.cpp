#include "pcl_delaunay_walk/core/registration/voxel_downsample.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

std::vector<float> voxelDownsample(const PointView& points, double leaf) {
  std::vector<float> out;
  std::vector<std::array<double, 3>> finite;
  finite.reserve(points.size);
  for (std::size_t i = 0; i < points.size; ++i) {
    const auto p = points[i];
    if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) finite.push_back(p);
  }
  if (!(leaf > 0)) {
    out.reserve(3 * finite.size());
    for (const auto& p : finite) out.insert(out.end(), {float(p[0]), float(p[1]), float(p[2])});
    return out;
  }
  if (finite.empty()) return out;
  std::array<double, 3> lo = finite[0];
  for (const auto& p : finite)
    for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], p[c]);
  std::array<std::int64_t, 3> base;
  for (int c = 0; c < 3; ++c) base[c] = static_cast<std::int64_t>(std::floor(lo[c] / leaf));
  constexpr std::int64_t kMax = (std::int64_t(1) << 21) - 1;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(finite.size());
  for (std::size_t i = 0; i < finite.size(); ++i) {
    std::uint64_t key = 0;
    for (int c = 0; c < 3; ++c) {
      const std::int64_t v = static_cast<std::int64_t>(std::floor(finite[i][c] / leaf)) - base[c];
      if (v < 0 || v > kMax)
        throw Error("dw::voxelDownsample: the cloud spans more than 2^21 voxels of " + std::to_string(leaf) +
                    " along one axis");
      key = (key << 21) | std::uint64_t(v);
    }
    keyed[i] = {key, std::uint32_t(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  for (std::size_t b = 0; b < keyed.size();) {
    std::size_t e = b;
    double s[3] = {0, 0, 0};
    for (; e < keyed.size() && keyed[e].first == keyed[b].first; ++e)
      for (int c = 0; c < 3; ++c) s[c] += finite[keyed[e].second][c];
    const double cnt = double(e - b);
    out.insert(out.end(), {float(s[0] / cnt), float(s[1] / cnt), float(s[2] / cnt)});
    b = e;
  }
  return out;
}

}  // namespace dw
