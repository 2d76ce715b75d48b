/// \file surface_sampler.h
/// \brief The dense prior map: points drawn uniformly by area on every surface of an UrbanScene that
/// can be seen from outside (no box bottoms, no walls under the ground or inside another solid), as a
/// survey vehicle's accumulated and cleaned map would hold them, at any density.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "pcl_delaunay_walk/core/sim/urban_scene.h"

namespace dw {
namespace sim {

struct SurfaceSamplingOptions {
  std::uint64_t points = 10000000;  ///< exactly this many points come back
  std::uint64_t seed = 1;
  double noise = 0.0;  ///< standard deviation of an isotropic Gaussian jitter (m)
  unsigned threads = 0;
  std::function<void(double)> progress;  ///< fraction done, called from one thread at a time
};

struct SurfaceSamples {
  std::vector<float> xyz;         ///< 3 per point, map frame
  std::vector<SurfaceKind> kind;  ///< one per point
  std::size_t size() const { return kind.size(); }
};

/// Samples the scene's visible surfaces. The same options give the same points for any thread count.
/// Throws dw::Error for a point count of 0 or beyond 2^32 - 1, or a scene with no area.
SurfaceSamples sampleSurfaces(const UrbanScene& scene, const SurfaceSamplingOptions& options);

}  // namespace sim
}  // namespace dw
