/// \file urban_scene.h
/// \brief A synthetic urban scene for localization and odometry data: a gently sloped, undulating
/// ground over a grid of streets and blocks; buildings as boxes with facade ledges and pilasters; poles
/// with lamp arms; trees as a trunk with one to three ellipsoid crown blobs; parked cars as a body and
/// a cabin box. Every surface is an analytic primitive, so a ray finds its exact first hit (the LiDAR
/// model, lidar_sensor.h) and a point's distance to the nearest surface is known (the tests use it).
///
/// Frame: x east, y north, z up, metres; street centrelines at x = i * pitch and y = j * pitch.
/// The layout is a pure function of UrbanSceneOptions (seed included).
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace dw {
namespace sim {

/// What a surface is; the map writer turns it into a LAS class, the sensor into a reflectivity.
enum class SurfaceKind : std::uint8_t { Ground, Building, Facade, Pole, Trunk, Crown, Car };

/// The ground: a plane of gentle slope plus two bounded undulations,
///   z = base + slope_x x + slope_y y + undulation(x, y) + roughness(x, y),
/// |undulation| <= undulation_amplitude, |roughness| <= roughness_amplitude. It exists only over the
/// scene's rectangle; rays leaving it see nothing.
struct GroundModel {
  double base = 0.0;
  double slope_x = 0.0, slope_y = 0.0;
  double undulation_amplitude = 0.0, undulation_wavelength = 80.0;
  double roughness_amplitude = 0.0, roughness_wavelength = 6.0;
  double phase[4] = {0.0, 0.0, 0.0, 0.0};

  double height(double x, double y) const;
  /// The bound on |height - plane|: the ray caster brackets its ground hit with it.
  double maxDeviation() const { return undulation_amplitude + roughness_amplitude; }
};

/// One solid: a box rotated by `yaw` about z (half extents `half`), a vertical capped cylinder
/// (radius half.x, half height half.z) or an axis-aligned ellipsoid (radii `half`), centred at `centre`.
struct Primitive {
  enum class Shape : std::uint8_t { Box, Cylinder, Ellipsoid };
  Shape shape = Shape::Box;
  SurfaceKind kind = SurfaceKind::Building;
  float reflectivity = 0.5f;  ///< in [0, 1]: what the sensor reports at normal incidence
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half = Eigen::Vector3d::Ones();
  double yaw = 0.0;                     ///< boxes only
  double cos_yaw = 1.0, sin_yaw = 0.0;  ///< of `yaw`, set by box(): every ray test needs them

  static Primitive box(SurfaceKind kind, const Eigen::Vector3d& centre, const Eigen::Vector3d& half,
                       double yaw, float reflectivity);
  static Primitive cylinder(SurfaceKind kind, double x, double y, double z0, double z1, double radius,
                            float reflectivity);
  static Primitive ellipsoid(SurfaceKind kind, const Eigen::Vector3d& centre, const Eigen::Vector3d& radii,
                             float reflectivity);

  /// Signed distance of p to the surface (negative inside); exact for boxes and cylinders, the usual
  /// first-order estimate for ellipsoids (exact on the surface, within a few per cent of the gap
  /// near it).
  double signedDistance(const Eigen::Vector3d& p) const;
  /// First t in (t_min, t_max) where o + t d meets the surface from outside; writes the outward unit
  /// normal. A ray starting inside the solid does not hit it.
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_max, double& t,
                 Eigen::Vector3d& normal) const;
  /// Axis-aligned bounds in x and y (lo_x, lo_y, hi_x, hi_y).
  Eigen::Vector4d footprint() const;
};

/// The street grid the trajectory drives on: intersections at (i * pitch, j * pitch) for
/// 0 <= i < nodes_x, 0 <= j < nodes_y.
struct StreetLayout {
  int nodes_x = 0, nodes_y = 0;
  double pitch = 0.0;
  double street_width = 0.0;
};

struct UrbanSceneOptions {
  std::uint64_t seed = 1;
  int blocks_x = 5, blocks_y = 5;  ///< blocks between streets (the street grid has one more line)
  double block_size = 60.0;        ///< edge of a block, sidewalks included (m)
  double street_width = 16.0;      ///< curb to curb (m)
  double sidewalk_width = 3.5;
  double park_fraction = 0.15;  ///< share of blocks that are parks (trees) instead of buildings
  double min_height = 6.0, max_height = 32.0;
  double car_density = 0.5;  ///< share of the curb length with parked cars
  GroundModel ground{0.0, 0.008, -0.005, 0.3, 80.0, 0.03, 6.0, {0.3, 1.1, 2.0, 0.7}};
};

/// The result of a ray query.
struct RayHit {
  double t = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  SurfaceKind kind = SurfaceKind::Ground;
  float reflectivity = 0.0f;
  std::int32_t primitive = -1;  ///< -1: the ground
};

class UrbanScene {
 public:
  /// The procedural city of `options` (deterministic for a seed).
  static UrbanScene generate(const UrbanSceneOptions& options);

  /// A scene of only the ground over [x0, x1] x [y0, y1]; add primitives, then query. Tests build
  /// scenes whose answers they know this way.
  UrbanScene(const GroundModel& ground, double x0, double y0, double x1, double y1);
  ~UrbanScene();
  UrbanScene(UrbanScene&&) noexcept;
  UrbanScene& operator=(UrbanScene&&) noexcept;

  /// Not while another thread queries the scene.
  void addPrimitive(const Primitive& p);

  /// Nearest hit of the ray o + t d (d unit) with t in (t_min, t_max). Thread-safe.
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_max,
                 RayHit& hit) const;
  /// Distance of p to the nearest surface (the ground by its vertical gap, an upper bound within
  /// 1 + slope^2 / 2 of the true one), capped at `cap`.
  double surfaceDistance(const Eigen::Vector3d& p, double cap = 5.0) const;
  /// True if p is deeper than `margin` inside a primitive other than `except`, or more than `margin`
  /// below the ground: such a point cannot be seen.
  bool hidden(const Eigen::Vector3d& p, std::int32_t except, double margin) const;

  const GroundModel& ground() const { return ground_; }
  const std::vector<Primitive>& primitives() const { return primitives_; }
  const StreetLayout& streets() const { return streets_; }
  /// The rectangle of the ground: lo_x, lo_y, hi_x, hi_y.
  const Eigen::Vector4d& extent() const { return extent_; }

 private:
  struct Grid;
  const Grid& grid() const;
  bool intersectGround(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_max,
                       double& t) const;

  GroundModel ground_;
  Eigen::Vector4d extent_;
  StreetLayout streets_;
  std::vector<Primitive> primitives_;
  mutable std::unique_ptr<Grid> grid_;  ///< built on the first query after the last addPrimitive
  std::unique_ptr<std::mutex> grid_mutex_;
  /// grid_ once built: queries read it without the lock (every ray asks for the grid).
  mutable std::atomic<const Grid*> grid_ready_{nullptr};
};

}  // namespace sim
}  // namespace dw
