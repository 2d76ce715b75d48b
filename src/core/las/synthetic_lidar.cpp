/// \file synthetic_lidar.cpp
/// \brief Procedural airborne scene and scan pattern (see synthetic_lidar.h).
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_writer.h"

namespace dw {
namespace las {
namespace {

constexpr double kCell = 50.0;  // object look-up grid (metres)

struct Building {
  double cx, cy, hx, hy, cos_a, sin_a;  // centre, half sizes, orientation
  double base, eaves, ridge;            // ground, wall top, roof ridge (ridge == eaves: flat)
};
struct Tree {
  double cx, cy, r, base, top;  // crown radius, trunk base height, crown top
};

double terrain(double x, double y) {
  // Smooth hills at several wavelengths (metres): realistic slopes, no spikes.
  return 120.0 + 18.0 * std::sin(x / 310.0) * std::cos(y / 270.0) + 6.0 * std::sin(x / 83.0 + y / 121.0) +
         1.5 * std::sin(x / 17.0) * std::sin(y / 23.0);
}

class Scene {
 public:
  /// Objects of the tile whose south-west corner is (tx, ty) in the survey's frame; coordinates local.
  Scene(double w, double l, std::uint64_t seed, double tx, double ty)
      : nx_(std::size_t(w / kCell) + 1), ny_(std::size_t(l / kCell) + 1), tx_(tx), ty_(ty) {
    buildings_.resize(nx_ * ny_);
    trees_.resize(nx_ * ny_);
    std::mt19937_64 rng(seed * 7919 + 17);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (std::size_t j = 0; j < ny_; ++j)
      for (std::size_t i = 0; i < nx_; ++i) {
        const double x0 = i * kCell, y0 = j * kCell;
        // Districts: some cells are built up, some wooded, some open fields.
        const double kind = u(rng);
        if (kind < 0.35) {
          Building b;
          b.cx = x0 + 12 + 26 * u(rng);
          b.cy = y0 + 12 + 26 * u(rng);
          b.hx = 5 + 8 * u(rng);
          b.hy = 5 + 8 * u(rng);
          const double a = u(rng) * 3.14159265;
          b.cos_a = std::cos(a);
          b.sin_a = std::sin(a);
          b.base = terrain(tx + b.cx, ty + b.cy);
          b.eaves = b.base + 4 + 20 * u(rng);
          b.ridge = u(rng) < 0.5 ? b.eaves : b.eaves + 2 + 4 * u(rng);
          buildings_[j * nx_ + i].push_back(b);
        }
        const int trees =
            kind < 0.35 ? int(3 * u(rng)) : (kind < 0.7 ? 8 + int(12 * u(rng)) : int(2 * u(rng)));
        for (int t = 0; t < trees; ++t) {
          Tree tr;
          tr.cx = x0 + kCell * u(rng);
          tr.cy = y0 + kCell * u(rng);
          tr.r = 1.5 + 4 * u(rng);
          tr.base = terrain(tx + tr.cx, ty + tr.cy);
          tr.top = tr.base + 5 + 20 * u(rng);
          trees_[j * nx_ + i].push_back(tr);
        }
      }
  }

  /// Heights hit by a vertical pulse at (x, y): the first surface and whether it is a building or a
  /// crown (crowns let part of the pulse through to the ground).
  void probe(double x, double y, double* first, int* cls, double* crown_depth) const {
    const double g = terrain(tx_ + x, ty_ + y);
    *first = g;
    *cls = 2;
    *crown_depth = 0;
    const long ci = long(x / kCell), cj = long(y / kCell);
    for (long j = cj - 1; j <= cj + 1; ++j)
      for (long i = ci - 1; i <= ci + 1; ++i) {
        if (i < 0 || j < 0 || std::size_t(i) >= nx_ || std::size_t(j) >= ny_) continue;
        for (const Building& b : buildings_[std::size_t(j) * nx_ + std::size_t(i)]) {
          const double dx = x - b.cx, dy = y - b.cy;
          const double u = dx * b.cos_a + dy * b.sin_a, v = -dx * b.sin_a + dy * b.cos_a;
          if (std::fabs(u) > b.hx || std::fabs(v) > b.hy) continue;
          const double h = b.ridge - (b.ridge - b.eaves) * std::fabs(v) / b.hy;  // gable along u
          if (h > *first) {
            *first = h;
            *cls = 6;
          }
        }
        for (const Tree& t : trees_[std::size_t(j) * nx_ + std::size_t(i)]) {
          const double d2 = (x - t.cx) * (x - t.cx) + (y - t.cy) * (y - t.cy);
          if (d2 >= t.r * t.r) continue;
          const double h = t.top - (t.top - t.base) * 0.6 * d2 / (t.r * t.r);  // rounded crown
          if (h > *first) {
            *first = h;
            *cls = 5;
            *crown_depth = h - g;
          }
        }
      }
  }

 private:
  std::size_t nx_, ny_;
  double tx_, ty_;
  std::vector<std::vector<Building>> buildings_;
  std::vector<std::vector<Tree>> trees_;
};

std::int32_t quantise(double v, double offset, double scale) {
  return static_cast<std::int32_t>(std::llround((v - offset) / scale));
}

}  // namespace

LasHeader syntheticHeader(const LidarGenOptions& o) {
  LasHeader h;
  const bool big = o.num_points > 0xFFFFFFFFull;
  h.version_minor = big ? 4 : 2;
  h.point_format = big ? 6 : 1;
  h.scale[0] = h.scale[1] = h.scale[2] = o.scale;
  h.offset[0] = o.offset_x;
  h.offset[1] = o.offset_y;
  h.offset[2] = o.offset_z;
  h.software = "dw_lidar_gen";
  return h;
}

void generateLidar(const LidarGenOptions& o, const std::function<void(const LasRecord&)>& emit) {
  if (!(o.density > 0) || !(o.swath > 0) || !(o.scale > 0))
    throw Error("generateLidar: density, swath and scale must be positive");
  // Area for the requested number of returns (~1.15 returns per pulse), twice as long as wide
  // (flights run along y), so the TIN's strips cut across the flight lines.
  const double area = double(o.num_points) / (o.density * 1.15);
  const double width = std::max(10.0, std::sqrt(area / 2.0)), length = 2.0 * width;
  // Tile (c, r): its own objects and pulses, terrain and coordinates in the survey's frame.
  const std::uint64_t seed =
      o.seed + 0x9E3779B97F4A7C15ull * ((std::uint64_t(o.tile_row) << 32) | std::uint64_t(o.tile_col));
  const double tx = double(o.tile_col) * width, ty = double(o.tile_row) * length;
  const Scene scene(width, length, seed, tx, ty);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.15, 0.15), u01(0.0, 1.0);
  const double spacing = 1.0 / std::sqrt(o.density);  // across- and along-track pulse spacing
  const double swath = std::min(o.swath, width);
  const std::size_t lines = std::size_t(std::ceil(width / swath));
  std::uint64_t emitted = 0;
  double gps = 0.0;
  LasRecord r;
  for (std::size_t line = 0; emitted < o.num_points; ++line) {
    const std::size_t fl = line % lines;  // wrap around: a second pass, like a cross-flight
    const double x0 = fl * swath, x1 = std::min(width, x0 + swath);
    const bool north = (line % 2) == 0;
    const std::size_t scans = std::size_t(length / spacing);
    for (std::size_t s = 0; s < scans && emitted < o.num_points; ++s) {
      const double yline = north ? s * spacing : length - s * spacing;
      const std::size_t pulses = std::size_t((x1 - x0) / spacing);
      const bool left_to_right = (s % 2) == 0;  // oscillating mirror: zig-zag scan lines
      for (std::size_t p = 0; p < pulses && emitted < o.num_points; ++p) {
        const double t = double(p) / double(std::max<std::size_t>(1, pulses - 1));
        const double x = (left_to_right ? x0 + t * (x1 - x0) : x1 - t * (x1 - x0)) + jitter(rng) * spacing;
        // The forward motion during the sweep skews each scan line slightly.
        const double y = yline + (north ? 1 : -1) * t * spacing * 0.5 + jitter(rng) * spacing;
        if (x < 0 || x > width || y < 0 || y > length) continue;
        double first;
        int cls;
        double crown;
        scene.probe(x, y, &first, &cls, &crown);
        gps += 1e-5;
        const bool second = cls == 5 && u01(rng) < 0.6;  // part of a crown pulse reaches the ground
        const int n_ret = second ? 2 : 1;
        r.X = quantise(o.offset_x + tx + x, o.offset_x, o.scale);
        r.Y = quantise(o.offset_y + ty + y, o.offset_y, o.scale);
        r.Z = quantise(first + jitter(rng) * 0.1, o.offset_z, o.scale);
        r.classification = std::uint8_t(cls);
        r.return_number = 1;
        r.number_of_returns = std::uint8_t(n_ret);
        r.intensity = std::uint16_t(cls == 2 ? 300 + 200 * u01(rng) : (cls == 6 ? 800 : 150));
        r.gps_time = gps;
        r.scan_angle = std::int16_t((t - 0.5) * 30);
        r.point_source_id = std::uint16_t(line);
        emit(r);
        ++emitted;
        if (second && emitted < o.num_points) {
          r.Z = quantise(terrain(tx + x, ty + y) + jitter(rng) * 0.1, o.offset_z, o.scale);
          r.classification = 2;
          r.return_number = 2;
          emit(r);
          ++emitted;
        }
      }
    }
  }
}

std::uint64_t writeSyntheticLas(const std::string& path, const LidarGenOptions& options,
                                const std::function<void(double)>& progress) {
  LasWriter writer(path, syntheticHeader(options));
  std::uint64_t n = 0;
  const std::uint64_t step = std::max<std::uint64_t>(1, options.num_points / 100);
  generateLidar(options, [&](const LasRecord& r) {
    writer.write(r);
    if (++n % step == 0 && progress) progress(double(n) / double(options.num_points));
  });
  writer.close();
  return n;
}

}  // namespace las
}  // namespace dw
