// The spinning LiDAR: ray directions of the model, the cast of every ray, noise and intensity.
#include "pcl_delaunay_walk/core/sim/lidar_sensor.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/sim/sim_random.h"
#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace sim {

namespace {
constexpr double kDeg = 3.141592653589793 / 180.0;
}

LidarModel LidarModel::hdl64() {
  LidarModel m;
  for (int k = 0; k < 32; ++k) m.elevation_deg.push_back(2.0 - k * (2.0 + 8.33) / 31.0);
  for (int k = 0; k < 32; ++k) m.elevation_deg.push_back(-8.83 - k * (24.8 - 8.83) / 31.0);
  return m;
}

LidarModel LidarModel::uniform(int beams, double top_deg, double bottom_deg, int azimuth_steps) {
  LidarModel m;
  m.azimuth_steps = azimuth_steps;
  for (int k = 0; k < beams; ++k)
    m.elevation_deg.push_back(beams == 1 ? top_deg : top_deg + (bottom_deg - top_deg) * k / (beams - 1));
  return m;
}

void LidarModel::check() const {
  auto fail = [](const std::string& what) { throw Error("dw::sim::LidarModel: " + what); };
  if (elevation_deg.empty() || elevation_deg.size() > 1024) fail("needs 1 to 1024 beams");
  for (double e : elevation_deg)
    if (!(e > -90.0 && e < 90.0)) fail("beam elevations must lie in (-90, 90) degrees");
  if (azimuth_steps < 1 || azimuth_steps > 100000) fail("azimuth_steps must be in [1, 100000]");
  if (!(min_range >= 0.0 && max_range > min_range && max_range < 1e5))
    fail("ranges must satisfy 0 <= min_range < max_range < 1e5 m");
  if (!(range_noise >= 0.0 && range_noise < 10.0)) fail("range_noise must be in [0, 10) m");
}

LidarScan simulateScan(const UrbanScene& scene, const LidarModel& model, const Eigen::Isometry3d& pose,
                       std::uint64_t seed, std::uint64_t scan_index, unsigned threads) {
  model.check();
  const std::size_t beams = model.elevation_deg.size(),
                    columns = static_cast<std::size_t>(model.azimuth_steps);
  std::vector<double> ce(beams), se(beams);
  for (std::size_t b = 0; b < beams; ++b) {
    ce[b] = std::cos(model.elevation_deg[b] * kDeg);
    se[b] = std::sin(model.elevation_deg[b] * kDeg);
  }
  const std::uint64_t scan_key = detail::streamKey(seed, scan_index);
  const unsigned workers = workerCount(columns, threads, 64);
  std::vector<std::vector<float>> parts(workers);
  const Eigen::Matrix3d R = pose.linear();
  const Eigen::Vector3d origin = pose.translation();
  parallelFor(columns, workers, [&](std::size_t begin, std::size_t end, unsigned w) {
    std::vector<float>& out = parts[w];
    out.reserve((end - begin) * beams * 4);
    for (std::size_t c = begin; c < end; ++c) {
      const double az = 2.0 * 3.141592653589793 * static_cast<double>(c) / static_cast<double>(columns);
      const double ca = std::cos(az), sa = std::sin(az);
      for (std::size_t b = 0; b < beams; ++b) {
        const Eigen::Vector3d dir_s(ce[b] * ca, ce[b] * sa, se[b]);
        const Eigen::Vector3d dir = R * dir_s;
        RayHit hit;
        if (!scene.intersect(origin, dir, model.min_range, model.max_range, hit)) continue;
        detail::Rng rng(scan_key, c * beams + b);
        const double range = hit.t + model.range_noise * rng.normal();
        if (!(range > model.min_range && range < model.max_range)) continue;
        // Lambertian-like return: brighter head-on, never zero so grazing hits stay visible.
        const double cosine = std::fabs(hit.normal.dot(dir));
        const double intensity = std::clamp(hit.reflectivity * (0.25 + 0.75 * cosine), 0.0, 1.0);
        out.insert(out.end(), {static_cast<float>(range * dir_s.x()), static_cast<float>(range * dir_s.y()),
                               static_cast<float>(range * dir_s.z()), static_cast<float>(intensity)});
      }
    }
  });
  LidarScan scan;
  std::size_t total = 0;
  for (const auto& p : parts) total += p.size();
  scan.xyzi.reserve(total);
  for (const auto& p : parts) scan.xyzi.insert(scan.xyzi.end(), p.begin(), p.end());
  return scan;
}

}  // namespace sim
}  // namespace dw
