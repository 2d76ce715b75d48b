// Device-side pieces of the walk shared by the search kernels and the ICP loop (internal header).
#pragma once

#include <cooperative_groups.h>
#include <cuda_runtime.h>

#include <cstdint>

#include "pcl_delaunay_walk/gpu/delaunay_walk.h"

namespace pcl {
namespace gpu {
namespace detail {

constexpr std::uint32_t kInvalid = 0xffffffffu;

/// Squared distance in double from float coordinates: the differences are exact and the squares nearly
/// so, which makes the comparisons of the walk, the brute force and the host reference agree (ties aside,
/// to ~1e-16). Float d2 is not enough: for a query far from the data two distinct vertices can round
/// to the same float d2, and a walk that moves only on strict decrease would stop on that plateau
/// (seen on a collinear set with queries ~17 units away, 5% of the answers).
__device__ __forceinline__ double dist2(const float4& p, float qx, float qy, float qz) {
  const double dx = double(qx) - double(p.x), dy = double(qy) - double(p.y), dz = double(qz) - double(p.z);
  return __dadd_rn(__dadd_rn(__dmul_rn(dx, dx), __dmul_rn(dy, dy)), __dmul_rn(dz, dz));
}

__device__ __forceinline__ bool finite3(float x, float y, float z) {
  return isfinite(x) && isfinite(y) && isfinite(z);
}

/// (d, v) strictly better than (bd, bv): smaller distance, ties to the smaller vertex index.
__device__ __forceinline__ bool better(double d, std::uint32_t v, double bd, std::uint32_t bv) {
  return d < bd || (d == bd && v < bv);
}

/// Start vertex: the hint when it is a vertex, else the seed of the grid cell holding q (clamped, so
/// queries far outside the hull start on the nearest boundary cell).
__device__ __forceinline__ std::uint32_t startVertex(const DeviceGraphView& g, float qx, float qy, float qz,
                                                     std::uint32_t hint) {
  if (hint < g.num_vertices) return hint;
  if (!g.grid_seeds) return 0;
  const float q[3] = {qx, qy, qz};
  int c[3];
#pragma unroll
  for (int a = 0; a < 3; ++a) {
    const float f = (q[a] - g.grid_min[a]) * g.grid_inv_cell[a];
    // Compare in float before converting: a huge f would overflow the int conversion.
    c[a] = f <= 0.f ? 0 : (f >= float(g.grid_dim[a] - 1) ? g.grid_dim[a] - 1 : int(f));
  }
  return g.grid_seeds[(std::size_t(c[2]) * g.grid_dim[1] + c[1]) * g.grid_dim[0] + c[0]];
}

/// The walk with G lanes of a tile scanning one neighbourhood together (G = 1: one thread per query).
/// Moves to the strictly nearest neighbour while one is strictly nearer than the current vertex:
/// exact (a non-nearest vertex always has a strictly nearer Delaunay neighbour, DESIGN.md §3) and
/// terminating (the distance strictly decreases). Every lane of the tile returns the same result.
template <int G, typename Tile>
__device__ __forceinline__ std::uint32_t walkTile(const Tile& tile, const DeviceGraphView& g, float qx,
                                                  float qy, float qz, std::uint32_t v, double& d2_out,
                                                  std::uint32_t& steps) {
  double d2 = dist2(__ldg(g.points + v), qx, qy, qz);
  std::uint32_t s = 0;
  const unsigned lane = G == 1 ? 0u : tile.thread_rank();
  for (;;) {
    const std::uint32_t b = __ldg(g.offsets + v), e = __ldg(g.offsets + v + 1);
    double bd = d2;
    std::uint32_t bv = v;
    // Two chunks of G edges per pass, both loads issued before either is used: the common
    // neighbourhood (degree ~16) then costs one memory round trip instead of two at G = 8.
    for (std::uint32_t base = b; base < e; base += 2 * G) {
      const std::uint32_t k0 = base + lane, k1 = base + G + lane;
      float4 p0 = make_float4(INFINITY, INFINITY, INFINITY, 0.f), p1 = p0;
      std::uint32_t j0 = kInvalid, j1 = kInvalid;
      if (g.edge_points) {  // uniform branch: one 16-byte read holds x_j and j
        if (k0 < e) p0 = __ldg(g.edge_points + k0);
        if (k1 < e) p1 = __ldg(g.edge_points + k1);
        j0 = __float_as_uint(p0.w);
        j1 = __float_as_uint(p1.w);
      } else {
        if (k0 < e) j0 = __ldg(g.neighbours + k0);
        if (k1 < e) j1 = __ldg(g.neighbours + k1);
        if (k0 < e) p0 = __ldg(g.points + j0);
        if (k1 < e) p1 = __ldg(g.points + j1);
      }
      if (k0 < e) {
        const double d = dist2(p0, qx, qy, qz);
        if (better(d, j0, bd, bv)) {
          bd = d;
          bv = j0;
        }
      }
      if (k1 < e) {
        const double d = dist2(p1, qx, qy, qz);
        if (better(d, j1, bd, bv)) {
          bd = d;
          bv = j1;
        }
      }
    }
    if constexpr (G > 1) {
#pragma unroll
      for (int o = G / 2; o > 0; o /= 2) {
        const double od = tile.shfl_xor(bd, o);
        const std::uint32_t ov = tile.shfl_xor(bv, o);
        if (better(od, ov, bd, bv)) {
          bd = od;
          bv = ov;
        }
      }
    }
    // Only a strictly smaller distance moves: a tie with the current vertex means it is already nearest.
    if (!(bd < d2)) break;
    v = bv;
    d2 = bd;
    ++s;
  }
  d2_out = d2;
  steps = s;
  return v;
}

/// Thread-per-query walk (no tile).
struct NoTile {
  __device__ unsigned thread_rank() const { return 0; }
};

__device__ __forceinline__ std::uint32_t walkThread(const DeviceGraphView& g, float qx, float qy, float qz,
                                                    std::uint32_t v, double& d2, std::uint32_t& steps) {
  return walkTile<1>(NoTile{}, g, qx, qy, qz, v, d2, steps);
}

}  // namespace detail
}  // namespace gpu
}  // namespace pcl
