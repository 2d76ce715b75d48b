// The procedural city of UrbanScene::generate: blocks of buildings or parks between streets, sidewalk
// furniture, parked cars. One generator in a fixed order, so a seed always gives the same city.
#include <algorithm>
#include <cmath>
#include <string>

#include "core/sim/sim_random.h"
#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/sim/urban_scene.h"

namespace dw {
namespace sim {

namespace {

using detail::Rng;
constexpr double kPi = 3.141592653589793;
constexpr double kFloorHeight = 3.2;

struct Rect {
  double x0, y0, x1, y1;
  double w() const { return x1 - x0; }
  double h() const { return y1 - y0; }
};

class CityBuilder {
 public:
  CityBuilder(UrbanScene& scene, const UrbanSceneOptions& o, Rng& rng) : s_(scene), o_(o), rng_(rng) {}

  void block(const Rect& r) {
    const double sw = o_.sidewalk_width;
    const Rect inner{r.x0 + sw, r.y0 + sw, r.x1 - sw, r.y1 - sw};
    if (rng_.chance(o_.park_fraction))
      park(inner);
    else
      buildings(inner);
    sidewalk(r);
  }

  /// Cars along both curbs of the street segment from (ax, ay) to (bx, by), axis-aligned.
  void parkedCars(double ax, double ay, double bx, double by) {
    const bool along_x = ay == by;
    const double length = along_x ? bx - ax : by - ay;
    const double keep_clear = 0.5 * o_.street_width + 3.0;  // out of the intersections
    for (const double side : {-1.0, 1.0}) {
      const double lateral = side * (0.5 * o_.street_width - 1.1);
      double u = keep_clear + rng_.uniform(0.0, 4.0);
      while (u + 5.0 < length - keep_clear) {
        const double car_length = rng_.uniform(4.1, 4.9);
        if (rng_.chance(o_.car_density)) {
          const double c = u + 0.5 * car_length;
          const double x = along_x ? ax + c : ax + lateral, y = along_x ? ay + lateral : ay + c;
          const double yaw =
              (along_x ? 0.0 : 0.5 * kPi) + (rng_.chance(0.5) ? kPi : 0.0) + rng_.uniform(-0.04, 0.04);
          car(x, y, yaw, car_length);
        }
        u += car_length + rng_.uniform(0.8, 4.0);
      }
    }
  }

 private:
  double groundAt(double x, double y) const { return o_.ground.height(x, y); }
  /// Lowest the ground can be under a footprint (bottoms of solids go below it, so no gap shows).
  double groundBelow(const Rect& r) const {
    const GroundModel& g = o_.ground;
    double lo = HUGE_VAL;
    for (const double x : {r.x0, r.x1})
      for (const double y : {r.y0, r.y1}) lo = std::min(lo, g.base + g.slope_x * x + g.slope_y * y);
    return lo - g.maxDeviation() - 0.5;
  }

  void add(const Primitive& p) { s_.addPrimitive(p); }

  /// A box in the frame of a parent box: `offset` from its centre, rotated with it.
  Primitive attached(const Primitive& parent, SurfaceKind kind, const Eigen::Vector3d& offset,
                     const Eigen::Vector3d& half, float reflectivity) const {
    const double c = parent.cos_yaw, s = parent.sin_yaw;
    const Eigen::Vector3d w(c * offset.x() - s * offset.y(), s * offset.x() + c * offset.y(), offset.z());
    return Primitive::box(kind, parent.centre + w, half, parent.yaw, reflectivity);
  }

  void buildings(const Rect& inner) {
    const int nx = 2 + static_cast<int>(rng_.index(2)), ny = 2 + static_cast<int>(rng_.index(2));
    auto cuts = [&](double lo, double hi, int n) {
      std::vector<double> c{lo};
      for (int k = 1; k < n; ++k) c.push_back(lo + (hi - lo) * (k + rng_.uniform(-0.2, 0.2)) / n);
      c.push_back(hi);
      return c;
    };
    const auto cx = cuts(inner.x0, inner.x1, nx), cy = cuts(inner.y0, inner.y1, ny);
    for (int b = 0; b < ny; ++b)
      for (int a = 0; a < nx; ++a) {
        if (nx == 3 && ny == 3 && a == 1 && b == 1) continue;  // a courtyard
        const Rect lot{cx[a] + rng_.uniform(0.6, 2.5), cy[b] + rng_.uniform(0.6, 2.5),
                       cx[a + 1] - rng_.uniform(0.6, 2.5), cy[b + 1] - rng_.uniform(0.6, 2.5)};
        if (lot.w() > 5.0 && lot.h() > 5.0) building(lot);
      }
  }

  void building(const Rect& lot) {
    const double u = rng_.uniform();
    const double height = o_.min_height + (o_.max_height - o_.min_height) * u * u;
    const double yaw = rng_.uniform(-0.025, 0.025);
    const double sn = std::fabs(std::sin(yaw));
    double hx = 0.5 * lot.w(), hy = 0.5 * lot.h();
    // Shrink so that the turned box stays inside its lot.
    const double fx = hx - sn * hy, fy = hy - sn * hx;
    hx = fx;
    hy = fy;
    const double cxw = 0.5 * (lot.x0 + lot.x1), cyw = 0.5 * (lot.y0 + lot.y1);
    const double z_ground = groundAt(cxw, cyw), z_low = groundBelow(lot), z_top = z_ground + height;
    const float refl = static_cast<float>(rng_.uniform(0.35, 0.65));
    const Primitive body =
        Primitive::box(SurfaceKind::Building, Eigen::Vector3d(cxw, cyw, 0.5 * (z_low + z_top)),
                       Eigen::Vector3d(hx, hy, 0.5 * (z_top - z_low)), yaw, refl);
    add(body);
    const double zc = body.centre.z();
    for (int side = 0; side < 4; ++side) {
      const int axis = side % 2;                  // 0: the faces normal to local x, 1: to local y
      const double sign = side < 2 ? 1.0 : -1.0;  // which of the two
      const double normal_half = axis == 0 ? hx : hy, along_half = axis == 0 ? hy : hx;
      if (rng_.chance(0.55)) {
        // Floor ledges: 0.3 m out of the wall and 0.05 m into it, so no seam is visible.
        for (int f = 1; (f + 0.5) * kFloorHeight < height; ++f) {
          Eigen::Vector3d off = Eigen::Vector3d::Zero(), half(0.175, along_half, 0.11);
          off[axis] = sign * (normal_half + 0.125);
          off.z() = z_ground + f * kFloorHeight - zc;
          if (axis == 1) std::swap(half.x(), half.y());
          add(attached(body, SurfaceKind::Facade, off, half, refl + 0.1f));
        }
      }
      if (rng_.chance(0.35)) {
        const double spacing = rng_.uniform(3.5, 5.0);
        for (double a = -along_half + 0.5 * spacing; a < along_half - 0.3; a += spacing) {
          Eigen::Vector3d off = Eigen::Vector3d::Zero(), half(0.15, 0.22, 0.5 * (z_top - 0.2 - z_low));
          off[axis] = sign * (normal_half + 0.1);
          off[1 - axis] = a;
          off.z() = -0.1;
          if (axis == 1) std::swap(half.x(), half.y());
          add(attached(body, SurfaceKind::Facade, off, half, refl - 0.1f));
        }
      }
    }
    if (height > 12.0 && rng_.chance(0.3)) {  // a set-back top storey
      const double top = rng_.uniform(3.0, 9.0);
      Eigen::Vector3d off(rng_.uniform(-0.2, 0.2) * hx, rng_.uniform(-0.2, 0.2) * hy,
                          0.5 * (z_top - z_low) + 0.5 * top - 0.05);
      add(attached(
          body, SurfaceKind::Building, off,
          Eigen::Vector3d(rng_.uniform(0.45, 0.75) * hx, rng_.uniform(0.45, 0.75) * hy, 0.5 * top + 0.05),
          refl));
    }
  }

  void park(const Rect& inner) {
    const double spacing = 9.0;
    for (double y = inner.y0 + 0.5 * spacing; y < inner.y1; y += spacing)
      for (double x = inner.x0 + 0.5 * spacing; x < inner.x1; x += spacing)
        if (rng_.chance(0.7)) tree(x + rng_.uniform(-2.5, 2.5), y + rng_.uniform(-2.5, 2.5));
  }

  /// Poles and trees along the four sides of a block, on the sidewalk.
  void sidewalk(const Rect& r) {
    for (int side = 0; side < 4; ++side) {
      const bool along_x = side % 2 == 0;
      const double length = along_x ? r.w() : r.h();
      // Unit inward normal of this side, and the point where it starts.
      const double nx = along_x ? 0.0 : (side == 1 ? 1.0 : -1.0),
                   ny = along_x ? (side == 0 ? 1.0 : -1.0) : 0.0;
      const double ox = along_x ? r.x0 : (side == 1 ? r.x0 : r.x1),
                   oy = along_x ? (side == 0 ? r.y0 : r.y1) : r.y0;
      auto at = [&](double u, double inset, double& x, double& y) {
        x = ox + (along_x ? u : 0.0) + nx * inset;
        y = oy + (along_x ? 0.0 : u) + ny * inset;
      };
      std::vector<double> poles;
      for (double u = rng_.uniform(5.0, 15.0); u < length - 4.0; u += rng_.uniform(25.0, 35.0)) {
        double x, y;
        at(u, 0.7, x, y);
        pole(x, y, -nx, -ny);
        poles.push_back(u);
      }
      for (double u = rng_.uniform(3.0, 8.0); u < length - 3.0; u += rng_.uniform(9.0, 16.0)) {
        const bool near_pole =
            std::any_of(poles.begin(), poles.end(), [&](double p) { return std::fabs(p - u) < 2.5; });
        if (near_pole || !rng_.chance(0.6)) continue;
        double x, y;
        at(u, 1.8, x, y);
        tree(x, y);
      }
    }
  }

  void pole(double x, double y, double to_street_x, double to_street_y) {
    const double zg = groundAt(x, y), top = zg + rng_.uniform(6.0, 8.0);
    add(Primitive::cylinder(SurfaceKind::Pole, x, y, zg - 0.3, top, 0.1, 0.6f));
    add(Primitive::box(SurfaceKind::Pole,
                       Eigen::Vector3d(x + 0.8 * to_street_x, y + 0.8 * to_street_y, top - 0.25),
                       Eigen::Vector3d(0.8, 0.07, 0.07), std::atan2(to_street_y, to_street_x), 0.6f));
  }

  void tree(double x, double y) {
    const double zg = groundAt(x, y);
    const double trunk_height = rng_.uniform(2.2, 3.5), r = rng_.uniform(1.8, 3.0),
                 rz = rng_.uniform(1.6, 2.8);
    const Eigen::Vector3d crown(x, y, zg + trunk_height + 0.6 * rz);
    add(Primitive::cylinder(SurfaceKind::Trunk, x, y, zg - 0.3, zg + trunk_height + 0.5 * rz,
                            rng_.uniform(0.12, 0.22), 0.3f));
    add(Primitive::ellipsoid(SurfaceKind::Crown, crown, Eigen::Vector3d(r, r, rz), 0.25f));
    const int blobs = static_cast<int>(rng_.index(3));
    for (int k = 0; k < blobs; ++k) {
      const double f = rng_.uniform(0.55, 0.8);
      const Eigen::Vector3d off(rng_.uniform(-0.8, 0.8) * r, rng_.uniform(-0.8, 0.8) * r,
                                rng_.uniform(-0.3, 0.3) * rz);
      add(Primitive::ellipsoid(SurfaceKind::Crown, crown + off, Eigen::Vector3d(f * r, f * r, f * rz),
                               0.25f));
    }
  }

  void car(double x, double y, double yaw, double length) {
    const double zg = groundAt(x, y), clearance = 0.3, body = 0.9, cabin = 0.6;
    const float refl = static_cast<float>(rng_.uniform(0.3, 0.8));
    const Primitive b = Primitive::box(SurfaceKind::Car, Eigen::Vector3d(x, y, zg + clearance + 0.5 * body),
                                       Eigen::Vector3d(0.5 * length, 0.9, 0.5 * body), yaw, refl);
    add(b);
    add(attached(b, SurfaceKind::Car, Eigen::Vector3d(-0.15 * length, 0.0, 0.5 * body + 0.5 * cabin - 0.02),
                 Eigen::Vector3d(0.27 * length, 0.8, 0.5 * cabin + 0.02), refl));
  }

  UrbanScene& s_;
  const UrbanSceneOptions& o_;
  Rng& rng_;
};

void checkOptions(const UrbanSceneOptions& o) {
  auto fail = [](const std::string& what) { throw Error("dw::sim::UrbanScene::generate: " + what); };
  if (o.blocks_x < 1 || o.blocks_y < 1 || o.blocks_x > 200 || o.blocks_y > 200)
    fail("blocks_x and blocks_y must be in [1, 200]");
  if (!(o.street_width >= 6.0 && o.street_width <= 100.0)) fail("street_width must be in [6, 100] m");
  if (!(o.sidewalk_width >= 1.0 && o.block_size >= 2.0 * o.sidewalk_width + 10.0 && o.block_size <= 1000.0))
    fail("block_size must be in [2 sidewalk_width + 10, 1000] m and sidewalk_width >= 1 m");
  if (!(o.min_height > 0.0 && o.max_height >= o.min_height && o.max_height < 1000.0))
    fail("building heights must satisfy 0 < min_height <= max_height < 1000 m");
  if (!(o.park_fraction >= 0.0 && o.park_fraction <= 1.0 && o.car_density >= 0.0 && o.car_density <= 1.0))
    fail("park_fraction and car_density must be in [0, 1]");
  if (!(o.ground.undulation_wavelength > 0.0 && o.ground.roughness_wavelength > 0.0))
    fail("ground wavelengths must be > 0");
}

}  // namespace

UrbanScene UrbanScene::generate(const UrbanSceneOptions& options) {
  checkOptions(options);
  UrbanSceneOptions o = options;
  Rng rng(o.seed, 0xC17Cull);
  for (double& ph : o.ground.phase) ph = rng.uniform(0.0, 2.0 * kPi);
  const double pitch = o.block_size + o.street_width;
  const double margin = 0.5 * o.street_width + 15.0;
  UrbanScene scene(o.ground, -margin, -margin, o.blocks_x * pitch + margin, o.blocks_y * pitch + margin);
  scene.streets_ = {o.blocks_x + 1, o.blocks_y + 1, pitch, o.street_width};
  CityBuilder city(scene, o, rng);
  for (int j = 0; j < o.blocks_y; ++j)
    for (int i = 0; i < o.blocks_x; ++i) {
      const double x0 = i * pitch + 0.5 * o.street_width, y0 = j * pitch + 0.5 * o.street_width;
      city.block({x0, y0, x0 + o.block_size, y0 + o.block_size});
    }
  for (int j = 0; j <= o.blocks_y; ++j)
    for (int i = 0; i < o.blocks_x; ++i) city.parkedCars(i * pitch, j * pitch, (i + 1) * pitch, j * pitch);
  for (int i = 0; i <= o.blocks_x; ++i)
    for (int j = 0; j < o.blocks_y; ++j) city.parkedCars(i * pitch, j * pitch, i * pitch, (j + 1) * pitch);
  return scene;
}

}  // namespace sim
}  // namespace dw
