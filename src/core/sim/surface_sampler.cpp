// Area-weighted sampling of the scene's visible surfaces, in patches (ground tiles, one primitive each)
// so that the work spreads over threads and every patch draws from its own random stream.
#include "pcl_delaunay_walk/core/sim/surface_sampler.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>

#include "core/sim/sim_random.h"
#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace sim {

namespace {

using detail::Rng;
constexpr double kPi = 3.141592653589793;
constexpr double kGroundTile = 20.0;
/// How deep inside another solid (or under the ground) a sample must be to count as hidden: points on
/// a shared boundary stay.
constexpr double kHiddenMargin = 1e-3;

struct Patch {
  std::int32_t primitive;  // -1: a ground tile
  double x0, y0, x1, y1;   // ground tiles
  double area;
};

double boxArea(const Primitive& p) {  // four walls and the top: bottoms are never seen
  const Eigen::Vector3d e = 2.0 * p.half;
  return 2.0 * (e.x() + e.y()) * e.z() + e.x() * e.y();
}

double area(const Primitive& p) {
  switch (p.shape) {
    case Primitive::Shape::Box: return boxArea(p);
    case Primitive::Shape::Cylinder:
      return 2.0 * kPi * p.half.x() * 2.0 * p.half.z() + kPi * p.half.x() * p.half.x();
    case Primitive::Shape::Ellipsoid: {  // Knud Thomsen's formula, within 1.1 %
      const double q = 1.6075, a = std::pow(p.half.x(), q), b = std::pow(p.half.y(), q),
                   c = std::pow(p.half.z(), q);
      return 4.0 * kPi * std::pow((a * b + a * c + b * c) / 3.0, 1.0 / q);
    }
  }
  return 0.0;
}

Eigen::Vector3d boxPoint(const Primitive& p, Rng& rng) {
  const Eigen::Vector3d e = 2.0 * p.half;
  const double faces[3] = {e.y() * e.z(), e.x() * e.z(), e.x() * e.y()};  // x walls, y walls, top
  const double pick = rng.uniform() * (2.0 * faces[0] + 2.0 * faces[1] + faces[2]);
  Eigen::Vector3d q(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
  if (pick < 2.0 * faces[0])
    q.x() = pick < faces[0] ? -1.0 : 1.0;
  else if (pick < 2.0 * faces[0] + 2.0 * faces[1])
    q.y() = pick < 2.0 * faces[0] + faces[1] ? -1.0 : 1.0;
  else
    q.z() = 1.0;
  q = q.cwiseProduct(p.half);
  const double c = p.cos_yaw, s = p.sin_yaw;
  return p.centre + Eigen::Vector3d(c * q.x() - s * q.y(), s * q.x() + c * q.y(), q.z());
}

Eigen::Vector3d cylinderPoint(const Primitive& p, Rng& rng) {
  const double r = p.half.x(), side = 2.0 * kPi * r * 2.0 * p.half.z(), top = kPi * r * r;
  const double a = rng.uniform(0.0, 2.0 * kPi);
  if (rng.uniform() * (side + top) < side)
    return p.centre + Eigen::Vector3d(r * std::cos(a), r * std::sin(a), rng.uniform(-1.0, 1.0) * p.half.z());
  const double rho = r * std::sqrt(rng.uniform());
  return p.centre + Eigen::Vector3d(rho * std::cos(a), rho * std::sin(a), p.half.z());
}

/// Uniform by area: a uniform direction u on the unit sphere maps to centre + radii * u, whose area
/// element is proportional to |u / radii| radii.prod(); keeping u with probability
/// |u / radii| min(radii) corrects the density.
Eigen::Vector3d ellipsoidPoint(const Primitive& p, Rng& rng) {
  for (;;) {
    const double z = rng.uniform(-1.0, 1.0), a = rng.uniform(0.0, 2.0 * kPi), s = std::sqrt(1.0 - z * z);
    const Eigen::Vector3d u(s * std::cos(a), s * std::sin(a), z);
    if (rng.uniform() < u.cwiseQuotient(p.half).norm() * p.half.minCoeff())
      return p.centre + u.cwiseProduct(p.half);
  }
}

std::vector<Patch> makePatches(const UrbanScene& scene) {
  std::vector<Patch> patches;
  const Eigen::Vector4d e = scene.extent();
  for (double y = e[1]; y < e[3]; y += kGroundTile)
    for (double x = e[0]; x < e[2]; x += kGroundTile) {
      const double x1 = std::min(e[2], x + kGroundTile), y1 = std::min(e[3], y + kGroundTile);
      patches.push_back({-1, x, y, x1, y1, (x1 - x) * (y1 - y)});
    }
  for (std::size_t i = 0; i < scene.primitives().size(); ++i)
    patches.push_back({static_cast<std::int32_t>(i), 0, 0, 0, 0, area(scene.primitives()[i])});
  return patches;
}

/// Draws `count` candidates on patch `k` and keeps the visible ones.
void samplePatch(const UrbanScene& scene, const Patch& patch, std::uint64_t count, double noise, Rng& rng,
                 std::vector<float>& xyz, std::vector<SurfaceKind>& kind) {
  const GroundModel& g = scene.ground();
  const Primitive* prim =
      patch.primitive >= 0 ? &scene.primitives()[static_cast<std::size_t>(patch.primitive)] : nullptr;
  for (std::uint64_t n = 0; n < count; ++n) {
    Eigen::Vector3d p;
    if (!prim) {
      const double x = rng.uniform(patch.x0, patch.x1), y = rng.uniform(patch.y0, patch.y1);
      p = Eigen::Vector3d(x, y, g.height(x, y));
    } else if (prim->shape == Primitive::Shape::Box) {
      p = boxPoint(*prim, rng);
    } else if (prim->shape == Primitive::Shape::Cylinder) {
      p = cylinderPoint(*prim, rng);
    } else {
      p = ellipsoidPoint(*prim, rng);
    }
    if (scene.hidden(p, patch.primitive, kHiddenMargin)) continue;
    if (noise > 0.0) p += noise * Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal());
    xyz.insert(xyz.end(), {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())});
    kind.push_back(prim ? prim->kind : SurfaceKind::Ground);
  }
}

}  // namespace

SurfaceSamples sampleSurfaces(const UrbanScene& scene, const SurfaceSamplingOptions& o) {
  if (o.points == 0 || o.points > 0xFFFFFFFFull)
    throw Error("dw::sim::sampleSurfaces: the point count must be in [1, 2^32 - 1]");
  if (!(o.noise >= 0.0 && o.noise < 10.0)) throw Error("dw::sim::sampleSurfaces: noise must be in [0, 10) m");
  const std::vector<Patch> patches = makePatches(scene);
  double total_area = 0;
  for (const auto& p : patches) total_area += p.area;
  if (!(total_area > 0)) throw Error("dw::sim::sampleSurfaces: the scene has no surface area");

  SurfaceSamples out;
  std::mutex progress_mutex;
  std::uint64_t drawn = 0;
  // Rounds: draw by area, keep what is visible; draw again for the shortfall (scaled by the
  // acceptance seen so far) until there are enough, then keep exactly `points` of them.
  for (std::uint64_t round = 0; out.size() < o.points; ++round) {
    if (round == 64) throw Error("dw::sim::sampleSurfaces: almost no surface is visible");
    const double acceptance = drawn ? std::max(0.01, static_cast<double>(out.size()) / drawn) : 0.9;
    const double want = static_cast<double>(o.points - out.size()) / acceptance * 1.02 + 64.0;
    std::vector<std::uint64_t> count(patches.size());
    double cum = 0;
    std::uint64_t given = 0;
    for (std::size_t k = 0; k < patches.size(); ++k) {  // cumulative rounding: the counts sum to `want`
      cum += want * patches[k].area / total_area;
      const std::uint64_t upto = static_cast<std::uint64_t>(std::llround(cum));
      count[k] = upto - given;
      given = upto;
      drawn += count[k];
    }
    std::vector<std::vector<float>> xyz(patches.size());
    std::vector<std::vector<SurfaceKind>> kind(patches.size());
    std::atomic<std::size_t> done{0};
    parallelForDynamic(patches.size(), o.threads, [&](std::size_t k) {
      Rng rng(o.seed, detail::streamKey(round, k));
      samplePatch(scene, patches[k], count[k], o.noise, rng, xyz[k], kind[k]);
      const std::size_t d = ++done;
      if (o.progress && d % 64 == 0) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        o.progress(std::min(
            1.0, (static_cast<double>(out.size()) + want * d / patches.size() * acceptance) / o.points));
      }
    });
    for (std::size_t k = 0; k < patches.size(); ++k) {
      out.xyz.insert(out.xyz.end(), xyz[k].begin(), xyz[k].end());
      out.kind.insert(out.kind.end(), kind[k].begin(), kind[k].end());
    }
  }
  // Knuth's selection sampling: exactly `points` of the n, each subset equally likely, order kept.
  const std::size_t n = out.size();
  if (n > o.points) {
    Rng rng(o.seed, 0x5E1Eull);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n && kept < o.points; ++i) {
      if (rng.uniform() * static_cast<double>(n - i) >= static_cast<double>(o.points - kept)) continue;
      for (int c = 0; c < 3; ++c) out.xyz[3 * kept + c] = out.xyz[3 * i + c];
      out.kind[kept] = out.kind[i];
      ++kept;
    }
    out.xyz.resize(3 * o.points);
    out.kind.resize(o.points);
  }
  if (o.progress) o.progress(1.0);
  return out;
}

}  // namespace sim
}  // namespace dw
