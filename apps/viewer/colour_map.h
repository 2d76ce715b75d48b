/// \file colour_map.h
/// \brief Colours of the viewer: a discrete scale for walk lengths (so that a length reads the same
/// in every iteration), a continuous hypsometric ramp for TIN heights, and a ramp for distances to a map.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace dw_viewer {

using Rgb = std::array<std::uint8_t, 3>;

namespace detail {

/// Piecewise-linear interpolation between anchor colours placed evenly on [0, 1].
template <std::size_t N>
inline Rgb rampColour(const std::array<Rgb, N>& anchors, double t) {
  if (!(t > 0)) return anchors.front();
  if (t >= 1) return anchors.back();
  const double s = t * (N - 1);
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(s), N - 2);
  const double f = s - k;
  Rgb c;
  for (int ch = 0; ch < 3; ++ch)
    c[ch] = static_cast<std::uint8_t>(std::lround((1 - f) * anchors[k][ch] + f * anchors[k + 1][ch]));
  return c;
}

}  // namespace detail

/// Colour of a walk of `steps` moves on a scale whose last colour is `scale` moves (and beyond):
/// 0 moves (the start was already the nearest) is cool blue, long walks hot red, so PNN's
/// convergence to 0-2 moves shows as the cloud turning blue.
inline Rgb walkColour(std::uint32_t steps, int scale) {
  static const std::array<Rgb, 5> anchors{
      {{{40, 70, 200}}, {{0, 170, 190}}, {{90, 200, 70}}, {{250, 200, 30}}, {{230, 40, 30}}}};
  return detail::rampColour(anchors, scale > 0 ? static_cast<double>(steps) / scale : 1.0);
}

/// Height colour: low green through ochre and brown to white peaks (a hypsometric tint), t in [0, 1].
inline Rgb heightColour(double t) {
  static const std::array<Rgb, 5> anchors{
      {{{30, 110, 60}}, {{120, 170, 70}}, {{215, 195, 110}}, {{150, 100, 60}}, {{245, 245, 245}}}};
  return detail::rampColour(anchors, t);
}

/// Colour of a distance to the map, t = distance / scale in [0, 1]: blue on the map, through cyan and
/// yellow to red at the scale and beyond. It stays away from pure green and magenta, the colours of
/// the trajectories drawn over it.
inline Rgb distanceColour(double t) {
  static const std::array<Rgb, 5> anchors{
      {{{50, 90, 230}}, {{0, 190, 210}}, {{250, 220, 40}}, {{240, 120, 20}}, {{220, 30, 30}}}};
  return detail::rampColour(anchors, t);
}

/// A robust value range: the `lo` and `hi` quantiles, so that a few outliers (birds, noise below
/// ground in LiDAR) do not flatten the colours of everything else. Returns {0, 1} for no values.
inline std::array<double, 2> quantileRange(std::vector<double> values, double lo = 0.01, double hi = 0.99) {
  if (values.empty()) return {{0.0, 1.0}};
  auto at = [&](double q) {
    const std::size_t k = static_cast<std::size_t>(q * (values.size() - 1));
    std::nth_element(values.begin(), values.begin() + k, values.end());
    return values[k];
  };
  std::array<double, 2> r{{at(lo), at(hi)}};
  if (!(r[1] > r[0])) r[1] = r[0] + 1.0;
  return r;
}

}  // namespace dw_viewer
