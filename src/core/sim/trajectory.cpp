// The route over the street grid, its rounded corners, and the poses sampled along it.
#include "pcl_delaunay_walk/core/sim/trajectory.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/sim/sim_random.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace sim {

namespace {

constexpr double kHalfPi = 1.5707963267948966;

/// One piece of the path: a straight from `a` along `dir`, or a quarter arc about `centre`.
struct Piece {
  bool arc = false;
  Eigen::Vector2d a = Eigen::Vector2d::Zero(), dir = Eigen::Vector2d::UnitX();  // straight: start, direction
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();                             // arc
  double radius = 0, angle0 = 0, turn = 0;  // arc: start angle about the centre, +1 left / -1 right
  double length = 0;
};

/// Heading-aligned position and heading at arc length u into `p`.
void evaluate(const Piece& p, double u, Eigen::Vector2d& pos, double& heading) {
  if (!p.arc) {
    pos = p.a + u * p.dir;
    heading = std::atan2(p.dir.y(), p.dir.x());
    return;
  }
  const double ang = p.angle0 + p.turn * u / p.radius;
  pos = p.centre + p.radius * Eigen::Vector2d(std::cos(ang), std::sin(ang));
  heading = ang + p.turn * kHalfPi;
}

/// Random route of intersections long enough for `length` metres, as rounded pieces.
std::vector<Piece> route(const StreetLayout& s, const TrajectoryOptions& o, double length, detail::Rng& rng) {
  const int dirs[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
  int i = static_cast<int>(rng.index(static_cast<std::uint64_t>(s.nodes_x)));
  int j = static_cast<int>(rng.index(static_cast<std::uint64_t>(s.nodes_y)));
  auto inside = [&](int x, int y) { return x >= 0 && y >= 0 && x < s.nodes_x && y < s.nodes_y; };
  int d = static_cast<int>(rng.index(4));
  while (!inside(i + dirs[d][0], j + dirs[d][1])) d = (d + 1) % 4;
  std::vector<Piece> pieces;
  const double r = o.corner_radius;
  Eigen::Vector2d cursor(i * s.pitch, j * s.pitch);  // where the next straight starts
  double total = 0;
  while (total < length + s.pitch) {
    i += dirs[d][0];
    j += dirs[d][1];
    // Choose the way on at (i, j): straight, left or right, weighted, among those inside the grid.
    const int options[3] = {d, (d + 1) % 4, (d + 3) % 4};
    const double weight[3] = {o.straight_probability, 0.5 * (1 - o.straight_probability),
                              0.5 * (1 - o.straight_probability)};
    double sum = 0, w[3];
    for (int k = 0; k < 3; ++k)
      sum += w[k] = inside(i + dirs[options[k]][0], j + dirs[options[k]][1]) ? weight[k] : 0;
    int next = d;
    if (sum <= 0) {
      next = (d + 2) % 4;  // a dead end cannot happen on a 2 x 2 grid or larger; kept for safety
    } else {
      double pick = rng.uniform() * sum;
      for (int k = 0; k < 3; ++k) {
        if (w[k] <= 0) continue;
        next = options[k];
        if ((pick -= w[k]) < 0) break;
      }
    }
    const Eigen::Vector2d node(i * s.pitch, j * s.pitch), din(dirs[d][0], dirs[d][1]);
    const Eigen::Vector2d dout(dirs[next][0], dirs[next][1]);
    const bool turning = next != d;
    Piece straight;
    straight.a = cursor;
    straight.dir = din;
    straight.length = (node - cursor).norm() - (turning ? r : 0.0);
    pieces.push_back(straight);
    total += straight.length;
    if (turning) {
      Piece arc;
      arc.arc = true;
      arc.radius = r;
      arc.turn = din.x() * dout.y() - din.y() * dout.x() > 0 ? 1.0 : -1.0;
      const Eigen::Vector2d start = node - r * din, normal = arc.turn * Eigen::Vector2d(-din.y(), din.x());
      arc.centre = start + r * normal;
      arc.angle0 = std::atan2(start.y() - arc.centre.y(), start.x() - arc.centre.x());
      arc.length = r * kHalfPi;
      pieces.push_back(arc);
      total += arc.length;
      cursor = node + r * dout;
    } else {
      cursor = node;
    }
    d = next;
  }
  return pieces;
}

}  // namespace

std::vector<Eigen::Isometry3d> generateTrajectory(const UrbanScene& scene, const TrajectoryOptions& o,
                                                  std::size_t frames, std::uint64_t seed) {
  const StreetLayout& s = scene.streets();
  if (s.nodes_x < 2 || s.nodes_y < 2)
    throw Error("dw::sim::generateTrajectory: the scene has no street grid of at least 2 x 2 intersections");
  if (!(o.speed > 0 && o.speed < 100 && o.rate_hz > 0 && o.rate_hz <= 1000))
    throw Error("dw::sim::generateTrajectory: speed must be in (0, 100) m/s and rate_hz in (0, 1000]");
  if (!(o.corner_radius > 0 && o.corner_radius <= 0.5 * s.pitch && o.straight_probability >= 0 &&
        o.straight_probability <= 1 && o.wheelbase > 0 && o.sensor_height > 0))
    throw Error(
        "dw::sim::generateTrajectory: corner_radius must be in (0, pitch / 2], straight_probability "
        "in [0, 1], wheelbase and sensor_height > 0");
  detail::Rng rng(seed, 0x7A7Eull);
  const double step = o.speed / o.rate_hz;
  const auto pieces = route(s, o, step * static_cast<double>(frames), rng);
  const GroundModel& g = scene.ground();
  std::vector<Eigen::Isometry3d> poses;
  poses.reserve(frames);
  std::size_t piece = 0;
  double piece_start = 0;
  for (std::size_t k = 0; k < frames; ++k) {
    const double u = step * static_cast<double>(k);
    while (piece + 1 < pieces.size() && u >= piece_start + pieces[piece].length)
      piece_start += pieces[piece++].length;
    Eigen::Vector2d pos;
    double yaw;
    evaluate(pieces[piece], u - piece_start, pos, yaw);
    // Pitch and roll: the ground's slope over the wheelbase, along and across the heading.
    const Eigen::Vector2d fwd(std::cos(yaw), std::sin(yaw)), left(-fwd.y(), fwd.x());
    const double h = 0.5 * o.wheelbase;
    auto at = [&](const Eigen::Vector2d& p) { return g.height(p.x(), p.y()); };
    const double slope_fwd = (at(pos + h * fwd) - at(pos - h * fwd)) / o.wheelbase;
    const double slope_left = (at(pos + h * left) - at(pos - h * left)) / o.wheelbase;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(-std::atan(slope_fwd), Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(std::atan(slope_left), Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(pos.x(), pos.y(), at(pos) + o.sensor_height);
    poses.push_back(T);
  }
  return poses;
}

}  // namespace sim
}  // namespace dw
