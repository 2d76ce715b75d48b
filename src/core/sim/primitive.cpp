// Analytic ray intersection and signed distance of the scene's three solids.
#include <algorithm>
#include <cmath>

#include "pcl_delaunay_walk/core/sim/urban_scene.h"

namespace dw {
namespace sim {

namespace {

/// p in the box's own frame (rotation by -yaw about z, relative to the centre).
Eigen::Vector3d toBoxFrame(const Primitive& b, const Eigen::Vector3d& p) {
  const double c = b.cos_yaw, s = b.sin_yaw;
  const Eigen::Vector3d q = p - b.centre;
  return {c * q.x() + s * q.y(), -s * q.x() + c * q.y(), q.z()};
}

Eigen::Vector3d rotateDirToBox(const Primitive& b, const Eigen::Vector3d& d) {
  const double c = b.cos_yaw, s = b.sin_yaw;
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z()};
}

Eigen::Vector3d rotateDirFromBox(const Primitive& b, const Eigen::Vector3d& d) {
  const double c = b.cos_yaw, s = b.sin_yaw;
  return {c * d.x() - s * d.y(), s * d.x() + c * d.y(), d.z()};
}

bool intersectBox(const Primitive& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                  double t_max, double& t, Eigen::Vector3d& normal) {
  const Eigen::Vector3d q = toBoxFrame(b, o), e = rotateDirToBox(b, d);
  double t_near = -HUGE_VAL, t_far = HUGE_VAL;
  int axis = -1;
  for (int k = 0; k < 3; ++k) {
    if (e[k] == 0.0) {
      if (std::fabs(q[k]) > b.half[k]) return false;
      continue;
    }
    double t1 = (-b.half[k] - q[k]) / e[k], t2 = (b.half[k] - q[k]) / e[k];
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > t_near) {
      t_near = t1;
      axis = k;
    }
    t_far = std::min(t_far, t2);
    if (t_near > t_far) return false;
  }
  // t_near <= 0 means the origin is inside: the surface is not seen from there.
  if (axis < 0 || t_near <= t_min || t_near >= t_max || t_near <= 0.0) return false;
  t = t_near;
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  n[axis] = e[axis] > 0 ? -1.0 : 1.0;
  normal = rotateDirFromBox(b, n);
  return true;
}

bool intersectCylinder(const Primitive& c, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                       double t_max, double& t, Eigen::Vector3d& normal) {
  const double r = c.half.x(), z0 = c.centre.z() - c.half.z(), z1 = c.centre.z() + c.half.z();
  const double ox = o.x() - c.centre.x(), oy = o.y() - c.centre.y();
  if (ox * ox + oy * oy <= r * r && o.z() >= z0 && o.z() <= z1) return false;  // inside
  bool found = false;
  double best = t_max;
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > 0.0) {
    const double bh = ox * d.x() + oy * d.y(), cc = ox * ox + oy * oy - r * r;
    const double disc = bh * bh - a * cc;
    if (disc >= 0.0) {
      const double ts = (-bh - std::sqrt(disc)) / a;
      const double z = o.z() + ts * d.z();
      if (ts > t_min && ts < best && z >= z0 && z <= z1) {
        best = ts;
        normal = Eigen::Vector3d(ox + ts * d.x(), oy + ts * d.y(), 0.0) / r;
        found = true;
      }
    }
  }
  if (d.z() != 0.0) {
    for (const double zc : {z0, z1}) {
      const double tc = (zc - o.z()) / d.z();
      if (tc <= t_min || tc >= best) continue;
      const double x = ox + tc * d.x(), y = oy + tc * d.y();
      if (x * x + y * y > r * r) continue;
      best = tc;
      normal = Eigen::Vector3d(0.0, 0.0, zc == z1 ? 1.0 : -1.0);
      found = true;
    }
  }
  if (found) t = best;
  return found;
}

bool intersectEllipsoid(const Primitive& e, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                        double t_max, double& t, Eigen::Vector3d& normal) {
  const Eigen::Vector3d q = (o - e.centre).cwiseQuotient(e.half), v = d.cwiseQuotient(e.half);
  const double a = v.squaredNorm(), b = q.dot(v), c = q.squaredNorm() - 1.0;
  if (c <= 0.0) return false;  // inside
  const double disc = b * b - a * c;
  if (disc < 0.0) return false;
  const double th = (-b - std::sqrt(disc)) / a;
  if (th <= t_min || th >= t_max) return false;
  t = th;
  normal = (q + th * v).cwiseQuotient(e.half).normalized();
  return true;
}

}  // namespace

Primitive Primitive::box(SurfaceKind kind, const Eigen::Vector3d& centre, const Eigen::Vector3d& half,
                         double yaw, float reflectivity) {
  Primitive p;
  p.shape = Shape::Box;
  p.kind = kind;
  p.centre = centre;
  p.half = half;
  p.yaw = yaw;
  p.cos_yaw = std::cos(yaw);
  p.sin_yaw = std::sin(yaw);
  p.reflectivity = reflectivity;
  return p;
}

Primitive Primitive::cylinder(SurfaceKind kind, double x, double y, double z0, double z1, double radius,
                              float reflectivity) {
  Primitive p;
  p.shape = Shape::Cylinder;
  p.kind = kind;
  p.centre = Eigen::Vector3d(x, y, 0.5 * (z0 + z1));
  p.half = Eigen::Vector3d(radius, radius, 0.5 * (z1 - z0));
  p.reflectivity = reflectivity;
  return p;
}

Primitive Primitive::ellipsoid(SurfaceKind kind, const Eigen::Vector3d& centre, const Eigen::Vector3d& radii,
                               float reflectivity) {
  Primitive p;
  p.shape = Shape::Ellipsoid;
  p.kind = kind;
  p.centre = centre;
  p.half = radii;
  p.reflectivity = reflectivity;
  return p;
}

double Primitive::signedDistance(const Eigen::Vector3d& p) const {
  switch (shape) {
    case Shape::Box: {
      const Eigen::Vector3d q = toBoxFrame(*this, p).cwiseAbs() - half;
      return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    case Shape::Cylinder: {
      const double dx = std::hypot(p.x() - centre.x(), p.y() - centre.y()) - half.x();
      const double dz = std::fabs(p.z() - centre.z()) - half.z();
      return std::hypot(std::max(dx, 0.0), std::max(dz, 0.0)) + std::min(std::max(dx, dz), 0.0);
    }
    case Shape::Ellipsoid: {
      const Eigen::Vector3d q = p - centre;
      const double k0 = q.cwiseQuotient(half).norm();
      const double k1 = q.cwiseQuotient(half.cwiseProduct(half)).norm();
      if (k1 == 0.0) return -half.minCoeff();
      return k0 * (k0 - 1.0) / k1;
    }
  }
  return HUGE_VAL;
}

bool Primitive::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_max,
                          double& t, Eigen::Vector3d& normal) const {
  switch (shape) {
    case Shape::Box: return intersectBox(*this, o, d, t_min, t_max, t, normal);
    case Shape::Cylinder: return intersectCylinder(*this, o, d, t_min, t_max, t, normal);
    case Shape::Ellipsoid: return intersectEllipsoid(*this, o, d, t_min, t_max, t, normal);
  }
  return false;
}

Eigen::Vector4d Primitive::footprint() const {
  double ex = half.x(), ey = half.y();
  if (shape == Shape::Box) {
    const double c = std::fabs(cos_yaw), s = std::fabs(sin_yaw);
    ex = c * half.x() + s * half.y();
    ey = s * half.x() + c * half.y();
  }
  return {centre.x() - ex, centre.y() - ey, centre.x() + ex, centre.y() + ey};
}

}  // namespace sim
}  // namespace dw
