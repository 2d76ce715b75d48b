#include "pcl_delaunay_walk/core/registration/voxel_downsample.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

std::vector<float> voxelDownsample(const PointView& points, double leaf) {
  std::vector<float> out;
  if (!(leaf > 0)) {
    // Full resolution runs on every frame of a localizer: one pass into the output. Float input is read
    // as floats (its values unchanged), 4-7x faster than through PointView's double accessor.
    out.resize(3 * points.size);
    std::size_t m = 0;
    const char* base = static_cast<const char*>(points.data);
    for (std::size_t i = 0; i < points.size; ++i) {
      float p[3];
      if (points.is_double) {  // finite in double, as the voxel path tests it
        const auto d = points[i];
        if (!(std::isfinite(d[0]) && std::isfinite(d[1]) && std::isfinite(d[2]))) continue;
        for (int c = 0; c < 3; ++c) p[c] = static_cast<float>(d[c]);
      } else {
        std::memcpy(p, base + i * points.stride, sizeof p);
        if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) continue;
      }
      out[m] = p[0], out[m + 1] = p[1], out[m + 2] = p[2];
      m += 3;
    }
    out.resize(m);
    return out;
  }
  std::vector<std::array<double, 3>> finite;
  finite.reserve(points.size);
  for (std::size_t i = 0; i < points.size; ++i) {
    const auto p = points[i];
    if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) finite.push_back(p);
  }
  if (finite.empty()) return out;
  // Voxel indices as three 64-bit integers; a point whose index would not fit (|x| / leaf >= 2^62,
  // e.g. a stray 1e30) has no voxel and is dropped like a non-finite one.
  using Key = std::array<std::int64_t, 3>;
  std::vector<std::pair<Key, std::uint32_t>> keyed;
  keyed.reserve(finite.size());
  constexpr double kLimit = 4.6e18;  // just under 2^62
  for (std::size_t i = 0; i < finite.size(); ++i) {
    Key key;
    bool fits = true;
    for (int c = 0; c < 3; ++c) {
      const double v = std::floor(finite[i][c] / leaf);
      fits = fits && std::fabs(v) < kLimit;
      key[c] = fits ? static_cast<std::int64_t>(v) : 0;
    }
    if (fits) keyed.emplace_back(key, std::uint32_t(i));
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
