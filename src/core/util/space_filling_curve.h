/// \file space_filling_curve.h
/// \brief The space-filling curves: Morton (Z-order) keys in 3D, which order the graph's vertices so
/// that graph neighbours are near in memory (3-6x faster walks than input order: docs/architecture.md,
/// "The walk graph"), and the 2D Hilbert key that orders the TIN strips' insertions.
#pragma once

#include <algorithm>
#include <cstdint>
#include <tuple>
#include <utility>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

/// Spreads the low 21 bits of v so that two zero bits separate consecutive bits.
inline std::uint64_t spreadBits21(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

/// 63-bit Morton key of a cell (each coordinate in [0, 2^21)).
inline std::uint64_t mortonKey(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  return spreadBits21(x) | spreadBits21(y) << 1 | spreadBits21(z) << 2;
}

/// The distinct points of `p` in Morton order over their bounding cube (exact repeats dropped): ids
/// then follow a space-filling curve, as buildDelaunayGraph hands points to the 3D builders. For tools,
/// tests and benchmarks that feed the builders directly.
inline std::vector<Vec3f> mortonSortedDistinct(const std::vector<Vec3f>& p) {
  if (p.empty()) return {};
  float lo[3] = {p[0].x, p[0].y, p[0].z}, hi[3] = {lo[0], lo[1], lo[2]};
  for (const Vec3f& q : p) {
    const float c[3] = {q.x, q.y, q.z};
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], c[k]), hi[k] = std::max(hi[k], c[k]);
  }
  const double ext = std::max({double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2], 1e-30});
  auto cell = [&](float v, int k) {
    return static_cast<std::uint32_t>((double(v) - lo[k]) / ext * 2097151.0);
  };
  std::vector<std::pair<std::uint64_t, Vec3f>> kv(p.size());
  for (std::size_t i = 0; i < p.size(); ++i)
    kv[i] = {mortonKey(cell(p[i].x, 0), cell(p[i].y, 1), cell(p[i].z, 2)), p[i]};
  std::sort(kv.begin(), kv.end(), [](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first < b.first;
    return std::tie(a.second.x, a.second.y, a.second.z) < std::tie(b.second.x, b.second.y, b.second.z);
  });
  std::vector<Vec3f> out;
  out.reserve(kv.size());
  for (const auto& e : kv)
    if (out.empty() || out.back().x != e.second.x || out.back().y != e.second.y || out.back().z != e.second.z)
      out.push_back(e.second);
  return out;
}

/// 32-bit Hilbert key of (x, y) in the box [x0, x0 + sx] x [y0, y0 + sy] (16 bits per axis), clamped to
/// the box. The 2D TIN's insertion order (brioHilbertSort) sorts by it within each BRIO round.
inline std::uint32_t hilbertKey(double x, double y, double x0, double y0, double inv_sx, double inv_sy) {
  constexpr double kMax = 65535.0;
  const double fx = std::min(kMax, std::max(0.0, (x - x0) * inv_sx * kMax));
  const double fy = std::min(kMax, std::max(0.0, (y - y0) * inv_sy * kMax));
  std::uint32_t ix = static_cast<std::uint32_t>(fx), iy = static_cast<std::uint32_t>(fy);
  // Table-driven Hilbert curve: a 4-state machine, two bits of the key per level. kNext[state][quad]
  // packs the output digit (low 2 bits) and the next state (bits 2-3); quad = 2 * xbit + ybit.
  // States: 0 identity, 1 transposed, 2 anti-transposed, 3 rotated by 180 degrees (checked against
  // the classic rotate-and-flip formulation in the tests).
  static constexpr std::uint8_t kNext[4][4] = {{0 | (1 << 2), 1 | (0 << 2), 3 | (2 << 2), 2 | (0 << 2)},
                                               {0 | (0 << 2), 3 | (3 << 2), 1 | (1 << 2), 2 | (1 << 2)},
                                               {2 | (2 << 2), 1 | (2 << 2), 3 | (0 << 2), 0 | (3 << 2)},
                                               {2 | (3 << 2), 3 | (1 << 2), 1 | (3 << 2), 0 | (2 << 2)}};
  std::uint32_t key = 0, state = 0;
  for (int level = 15; level >= 0; --level) {
    const std::uint32_t quad = (((ix >> level) & 1u) << 1) | ((iy >> level) & 1u);
    const std::uint8_t e = kNext[state][quad];
    key = (key << 2) | (e & 3u);
    state = e >> 2;
  }
  return key;
}

}  // namespace dw
