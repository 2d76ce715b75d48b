/// \file synthetic_street.h
/// \brief The localization benchmarks' generated street (bench/dw_localize_bench.cpp and
/// gpu/bench/bench_gpu_localize.cpp): a map of n points and scans cut from it around a sensor pose.
/// Timing data, not a sensor model.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <random>
#include <vector>

namespace dw_bench {

/// A synthetic street scene of n points over 400 x 400 m: ground (50 %), building walls (40 %), poles
/// (10 %), 1 cm noise. Timing data, not a sensor model: scans are cut from it around the sensor.
inline std::vector<float> syntheticStreet(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::normal_distribution<float> noise(0.f, 0.01f);
  struct Box {
    float x0, y0, x1, y1, h;
  };
  std::vector<Box> boxes;
  for (int i = -9; i <= 9; ++i)
    for (int side : {-1, 1}) {
      const float x0 = 20.f * float(i) + 2.f * u(rng), y0 = float(side) * (12.f + 4.f * u(rng));
      boxes.push_back({x0, side > 0 ? y0 : y0 - 15.f, x0 + 14.f + 4.f * u(rng), side > 0 ? y0 + 15.f : y0,
                       8.f + 20.f * u(rng)});
    }
  std::vector<float> out;
  out.reserve(3 * n);
  auto push = [&](float x, float y, float z) {
    out.insert(out.end(), {x + noise(rng), y + noise(rng), z + noise(rng)});
  };
  for (std::size_t i = 0; i < n; ++i) {
    const float r = u(rng);
    if (r < 0.5f) {
      const float x = -200.f + 400.f * u(rng), y = -200.f + 400.f * u(rng);
      push(x, y, 0.05f * std::sin(0.1f * x) + 0.03f * std::cos(0.13f * y));
    } else if (r < 0.9f) {
      const Box& b = boxes[std::size_t(u(rng) * float(boxes.size())) % boxes.size()];
      const float t = u(rng), z = b.h * u(rng);
      const int wall = int(u(rng) * 4) % 4;
      if (wall == 0)
        push(b.x0 + t * (b.x1 - b.x0), b.y0, z);
      else if (wall == 1)
        push(b.x0 + t * (b.x1 - b.x0), b.y1, z);
      else if (wall == 2)
        push(b.x0, b.y0 + t * (b.y1 - b.y0), z);
      else
        push(b.x1, b.y0 + t * (b.y1 - b.y0), z);
    } else {
      const int pole = int(u(rng) * 80) % 80;
      const float px = -190.f + 4.75f * float(pole), py = (pole % 2 ? 7.f : -7.f);
      const float a = 6.2831853f * u(rng);
      push(px + 0.15f * std::cos(a), py + 0.15f * std::sin(a), 6.f * u(rng));
    }
  }
  return out;
}

/// The order of a cut scan's points.
enum class ScanOrder {
  kSensor,  ///< column-major as a spinning LiDAR delivers them: by azimuth column, then elevation
  kRandom,  ///< shuffled: no two consecutive points are near (the worst case for warm starts)
};

/// The map points within `radius` of the sensor, thinned to about `target` points, in the sensor frame,
/// in `order`. Sensor order uses 2,048 azimuth columns (0.18 degrees, an HDL-64's step at 10 Hz).
inline std::vector<float> cutStreetScan(const std::vector<float>& map, const Eigen::Matrix4d& pose,
                                        double radius, std::size_t target, unsigned seed,
                                        ScanOrder order = ScanOrder::kSensor) {
  const Eigen::Vector3d c = pose.topRightCorner<3, 1>();
  std::vector<std::size_t> near;
  for (std::size_t i = 0; i < map.size() / 3; ++i) {
    const double dx = map[3 * i] - c(0), dy = map[3 * i + 1] - c(1), dz = map[3 * i + 2] - c(2);
    if (dx * dx + dy * dy + dz * dz <= radius * radius) near.push_back(i);
  }
  std::mt19937 rng(seed);
  std::shuffle(near.begin(), near.end(), rng);
  near.resize(std::min(near.size(), target));
  std::normal_distribution<double> noise(0.0, 0.01);
  const Eigen::Matrix4d inv = pose.inverse();
  struct Return {
    double key;
    float xyz[3];
  };
  std::vector<Return> returns;
  returns.reserve(near.size());
  for (std::size_t i : near) {
    const Eigen::Vector4d p(map[3 * i] + noise(rng), map[3 * i + 1] + noise(rng), map[3 * i + 2] + noise(rng),
                            1);
    const Eigen::Vector4d s = inv * p;
    const double column = std::floor((std::atan2(s(1), s(0)) + M_PI) / (2 * M_PI) * 2048.0);
    const double elevation = std::atan2(s(2), std::hypot(s(0), s(1)));  // in (-pi/2, pi/2)
    returns.push_back({column * 4.0 + elevation, {float(s(0)), float(s(1)), float(s(2))}});
  }
  if (order == ScanOrder::kSensor)
    std::sort(returns.begin(), returns.end(), [](const Return& a, const Return& b) { return a.key < b.key; });
  std::vector<float> out;
  out.reserve(3 * returns.size());
  for (const Return& r : returns) out.insert(out.end(), r.xyz, r.xyz + 3);
  return out;
}

}  // namespace dw_bench
