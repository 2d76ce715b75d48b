// The scene's queries: the ground height field, the uniform grid over the primitives' footprints, the
// nearest ray hit (2D grid traversal plus a bracketed search of the ground), distances and visibility.
#include "pcl_delaunay_walk/core/sim/urban_scene.h"

#include <algorithm>
#include <cmath>

namespace dw {
namespace sim {

namespace {
constexpr double kTwoPi = 6.283185307179586;
/// Grid cell edge: a few times a pole or a ledge, a fraction of a building, so a cell holds a handful
/// of primitives and a 120 m ray crosses at most ~40 cells.
constexpr double kCellSize = 4.0;
}  // namespace

double GroundModel::height(double x, double y) const {
  double z = base + slope_x * x + slope_y * y;
  if (undulation_amplitude != 0.0) {
    const double k = kTwoPi / undulation_wavelength;
    z += undulation_amplitude * std::sin(k * x + phase[0]) * std::cos(0.77 * k * y + phase[1]);
  }
  if (roughness_amplitude != 0.0) {
    const double k = kTwoPi / roughness_wavelength;
    z += roughness_amplitude * std::sin(k * (0.8 * x + 0.6 * y) + phase[2]) *
         std::sin(1.13 * k * (-0.6 * x + 0.8 * y) + phase[3]);
  }
  return z;
}

/// CSR lists of the primitives whose footprint overlaps each cell.
struct UrbanScene::Grid {
  double x0 = 0, y0 = 0;
  int nx = 1, ny = 1;
  std::vector<std::uint32_t> offsets, ids;

  int cellX(double x) const {
    return std::clamp(static_cast<int>(std::floor((x - x0) / kCellSize)), 0, nx - 1);
  }
  int cellY(double y) const {
    return std::clamp(static_cast<int>(std::floor((y - y0) / kCellSize)), 0, ny - 1);
  }
  const std::uint32_t* begin(int cx, int cy) const { return ids.data() + offsets[cy * nx + cx]; }
  const std::uint32_t* end(int cx, int cy) const { return ids.data() + offsets[cy * nx + cx + 1]; }
};

UrbanScene::UrbanScene(const GroundModel& ground, double x0, double y0, double x1, double y1)
    : ground_(ground), extent_(x0, y0, x1, y1), grid_mutex_(std::make_unique<std::mutex>()) {}
UrbanScene::~UrbanScene() = default;
UrbanScene::UrbanScene(UrbanScene&& o) noexcept
    : ground_(o.ground_),
      extent_(o.extent_),
      streets_(o.streets_),
      primitives_(std::move(o.primitives_)),
      grid_(std::move(o.grid_)),
      grid_mutex_(std::move(o.grid_mutex_)),
      grid_ready_(o.grid_ready_.exchange(nullptr)) {}

UrbanScene& UrbanScene::operator=(UrbanScene&& o) noexcept {
  ground_ = o.ground_;
  extent_ = o.extent_;
  streets_ = o.streets_;
  primitives_ = std::move(o.primitives_);
  grid_ = std::move(o.grid_);
  grid_mutex_ = std::move(o.grid_mutex_);
  grid_ready_.store(o.grid_ready_.exchange(nullptr));
  return *this;
}

void UrbanScene::addPrimitive(const Primitive& p) {
  std::lock_guard<std::mutex> lock(*grid_mutex_);
  primitives_.push_back(p);
  grid_ready_.store(nullptr);
  grid_.reset();
}

const UrbanScene::Grid& UrbanScene::grid() const {
  if (const Grid* ready = grid_ready_.load(std::memory_order_acquire)) return *ready;
  std::lock_guard<std::mutex> lock(*grid_mutex_);
  if (grid_) return *grid_;
  auto g = std::make_unique<Grid>();
  g->x0 = extent_[0];
  g->y0 = extent_[1];
  g->nx = std::max(1, static_cast<int>(std::ceil((extent_[2] - extent_[0]) / kCellSize)));
  g->ny = std::max(1, static_cast<int>(std::ceil((extent_[3] - extent_[1]) / kCellSize)));
  const std::size_t cells = static_cast<std::size_t>(g->nx) * g->ny;
  std::vector<std::uint32_t> count(cells + 1, 0);
  auto forCells = [&](const Primitive& p, auto&& fn) {
    const Eigen::Vector4d f = p.footprint();
    for (int cy = g->cellY(f[1]); cy <= g->cellY(f[3]); ++cy)
      for (int cx = g->cellX(f[0]); cx <= g->cellX(f[2]); ++cx) fn(static_cast<std::size_t>(cy) * g->nx + cx);
  };
  for (const auto& p : primitives_) forCells(p, [&](std::size_t c) { ++count[c + 1]; });
  for (std::size_t c = 0; c < cells; ++c) count[c + 1] += count[c];
  g->offsets = count;
  g->ids.resize(count[cells]);
  for (std::uint32_t i = 0; i < primitives_.size(); ++i)
    forCells(primitives_[i], [&](std::size_t c) { g->ids[count[c]++] = i; });
  grid_ = std::move(g);
  grid_ready_.store(grid_.get(), std::memory_order_release);
  return *grid_;
}

bool UrbanScene::intersectGround(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                                 double t_max, double& t) const {
  const GroundModel& g = ground_;
  const double dev = g.maxDeviation();
  // Height above the plane along the ray: q0 + t q1. The surface lies within dev of the plane, so a
  // crossing can only happen where |q| <= dev.
  const double q0 = o.z() - (g.base + g.slope_x * o.x() + g.slope_y * o.y());
  const double q1 = d.z() - g.slope_x * d.x() - g.slope_y * d.y();
  double ta = t_min, tb = t_max;
  if (q1 < 0.0) {
    ta = std::max(ta, (q0 - dev) / -q1);
    tb = std::min(tb, (q0 + dev) / -q1);
  } else if (q0 > dev) {
    return false;
  }
  if (dev == 0.0) {  // a plane: the crossing is q0 + t q1 = 0
    if (!(q1 < 0.0)) return false;
    t = q0 / -q1;
    const double x = o.x() + t * d.x(), y = o.y() + t * d.y();
    return t > t_min && t < t_max && x >= extent_[0] && x <= extent_[2] && y >= extent_[1] && y <= extent_[3];
  }
  if (!(ta < tb)) return false;
  auto f = [&](double s) { return o.z() + s * d.z() - g.height(o.x() + s * d.x(), o.y() + s * d.y()); };
  // Lipschitz stepping: along the ray f changes by at most `rate` per metre (|d_z| plus the bound
  // on the height field's gradient times |d_xy|), so a step of f / rate cannot pass a crossing. Below
  // kMinStep the steps stay kMinStep: a surface poking above the ray and back within 0.25 m would
  // need a curvature far beyond the field's. The first sign change is then refined by regula falsi
  // (Illinois): the field is smooth, so a few evaluations reach 1e-9 m where bisection needs ~40.
  constexpr double kMinStep = 0.25;
  const double dxy = std::hypot(d.x(), d.y());
  const double lipschitz = std::hypot(g.slope_x, g.slope_y) +
                           1.27 * g.undulation_amplitude * kTwoPi / g.undulation_wavelength +
                           1.52 * g.roughness_amplitude * kTwoPi / g.roughness_wavelength;
  const double rate = std::fabs(d.z()) + lipschitz * dxy + 1e-12;
  double s0 = ta, f0 = f(s0);
  if (f0 <= 0.0) {
    t = s0;
  } else {
    bool crossed = false;
    double s1 = s0, f1 = f0;
    while (s0 < tb) {
      s1 = std::min(tb, s0 + std::max(f0 / rate, kMinStep));
      f1 = f(s1);
      if (f1 <= 0.0) {
        crossed = true;
        break;
      }
      s0 = s1;
      f0 = f1;
    }
    if (!crossed) return false;
    int side = 0;
    double c = s1;
    for (int k = 0; k < 60 && s1 - s0 > 1e-9; ++k) {
      c = (s0 * f1 - s1 * f0) / (f1 - f0);
      if (!(c > s0 && c < s1)) c = 0.5 * (s0 + s1);
      const double fc = f(c);
      if (std::fabs(fc) < 1e-10) break;
      if (fc > 0.0) {
        s0 = c;
        f0 = fc;
        if (side > 0) f1 *= 0.5;
        side = 1;
      } else {
        s1 = c;
        f1 = fc;
        if (side < 0) f0 *= 0.5;
        side = -1;
      }
      c = s1;
    }
    t = c;
  }
  const double x = o.x() + t * d.x(), y = o.y() + t * d.y();
  return x >= extent_[0] && x <= extent_[2] && y >= extent_[1] && y <= extent_[3] && t > t_min;
}

bool UrbanScene::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_max,
                           RayHit& hit) const {
  const Grid& g = grid();
  double best = t_max;
  bool found = false;
  // The ray's span over the grid rectangle in x and y.
  double t_in = t_min, t_out = t_max;
  for (int k = 0; k < 2; ++k) {
    const double lo = extent_[k], hi = extent_[k + 2];
    if (d[k] == 0.0) {
      if (o[k] < lo || o[k] > hi) t_out = -1.0;
      continue;
    }
    double t1 = (lo - o[k]) / d[k], t2 = (hi - o[k]) / d[k];
    if (t1 > t2) std::swap(t1, t2);
    t_in = std::max(t_in, t1);
    t_out = std::min(t_out, t2);
  }
  if (t_in < t_out && !primitives_.empty()) {
    // Amanatides-Woo traversal of the cells the ray's xy shadow crosses.
    const Eigen::Vector3d start = o + t_in * d;
    int cx = g.cellX(start.x()), cy = g.cellY(start.y());
    const int sx = d.x() > 0 ? 1 : -1, sy = d.y() > 0 ? 1 : -1;
    auto boundary = [&](int c, int s, double origin, double dir, double cell0) {
      if (dir == 0.0) return HUGE_VAL;
      const double edge = cell0 + (c + (s > 0 ? 1 : 0)) * kCellSize;
      return (edge - origin) / dir;
    };
    double tx = boundary(cx, sx, o.x(), d.x(), g.x0), ty = boundary(cy, sy, o.y(), d.y(), g.y0);
    const double dtx = d.x() != 0.0 ? kCellSize / std::fabs(d.x()) : HUGE_VAL;
    const double dty = d.y() != 0.0 ? kCellSize / std::fabs(d.y()) : HUGE_VAL;
    for (;;) {
      for (const std::uint32_t* it = g.begin(cx, cy); it != g.end(cx, cy); ++it) {
        double t;
        Eigen::Vector3d n;
        if (primitives_[*it].intersect(o, d, t_min, best, t, n)) {
          best = t;
          found = true;
          hit.t = t;
          hit.normal = n;
          hit.primitive = static_cast<std::int32_t>(*it);
        }
      }
      const double t_exit = std::min(tx, ty);
      if (best <= t_exit || t_exit >= t_out) break;
      if (tx < ty) {
        cx += sx;
        tx += dtx;
        if (cx < 0 || cx >= g.nx) break;
      } else {
        cy += sy;
        ty += dty;
        if (cy < 0 || cy >= g.ny) break;
      }
    }
  }
  double tg;
  if (intersectGround(o, d, t_min, best, tg) && tg < best) {
    const double e = 0.05, x = o.x() + tg * d.x(), y = o.y() + tg * d.y();
    const double gx = (ground_.height(x + e, y) - ground_.height(x - e, y)) / (2 * e);
    const double gy = (ground_.height(x, y + e) - ground_.height(x, y - e)) / (2 * e);
    hit.t = tg;
    hit.normal = Eigen::Vector3d(-gx, -gy, 1.0).normalized();
    hit.primitive = -1;
    hit.kind = SurfaceKind::Ground;
    hit.reflectivity = 0.18f;
    return true;
  }
  if (found) {
    const Primitive& p = primitives_[static_cast<std::size_t>(hit.primitive)];
    hit.kind = p.kind;
    hit.reflectivity = p.reflectivity;
  }
  return found;
}

double UrbanScene::surfaceDistance(const Eigen::Vector3d& p, double cap) const {
  double best = cap;
  if (p.x() >= extent_[0] && p.x() <= extent_[2] && p.y() >= extent_[1] && p.y() <= extent_[3])
    best = std::min(best, std::fabs(p.z() - ground_.height(p.x(), p.y())));
  const Grid& g = grid();
  for (int cy = g.cellY(p.y() - cap); cy <= g.cellY(p.y() + cap); ++cy)
    for (int cx = g.cellX(p.x() - cap); cx <= g.cellX(p.x() + cap); ++cx)
      for (const std::uint32_t* it = g.begin(cx, cy); it != g.end(cx, cy); ++it)
        best = std::min(best, std::fabs(primitives_[*it].signedDistance(p)));
  return best;
}

bool UrbanScene::hidden(const Eigen::Vector3d& p, std::int32_t except, double margin) const {
  if (p.x() >= extent_[0] && p.x() <= extent_[2] && p.y() >= extent_[1] && p.y() <= extent_[3] &&
      p.z() < ground_.height(p.x(), p.y()) - margin)
    return true;
  const Grid& g = grid();
  const int cx = g.cellX(p.x()), cy = g.cellY(p.y());
  for (const std::uint32_t* it = g.begin(cx, cy); it != g.end(cx, cy); ++it)
    if (static_cast<std::int32_t>(*it) != except && primitives_[*it].signedDistance(p) < -margin) return true;
  return false;
}

}  // namespace sim
}  // namespace dw
