// Device-side pieces of the walk shared by the search kernels and the ICP loop (internal header).
#pragma once

#include <cooperative_groups.h>
#include <cuda_runtime.h>

#include <cstdint>

#include "pcl_delaunay_walk/gpu/delaunay_walk.h"

namespace dw {
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

/// Squared distance in float: every IEEE operation is correctly rounded and all three terms are >= 0,
/// so the result is within 5 ulp-units (relative 5 * 2^-24 = 3e-7) of the exact value while it stays a
/// normal float. The walk decides in float whenever the two sides differ by more than kFloatTol and
/// re-decides in double (dist2) only inside that band.
__device__ __forceinline__ float dist2f(const float4& p, float qx, float qy, float qz) {
  const float dx = qx - p.x, dy = qy - p.y, dz = qz - p.z;
  return fmaf(dx, dx, fmaf(dy, dy, dz * dz));
}

/// Relative band in which float squared distances cannot order two vertices (2 * 5u plus the rounding
/// of the product d * (1 -+ kFloatTol) itself, with margin).
constexpr float kFloatTol = 1.0f / (1 << 20);
/// Below this the float distances may be subnormal and lose their relative bound: decide in double.
constexpr float kFloatMin = 1e-30f;

__device__ __forceinline__ bool betterF(float d, std::uint32_t v, float bd, std::uint32_t bv) {
  return d < bd || (d == bd && v < bv);
}

/// One pass over the neighbourhood of v by the G lanes of a tile: the nearest neighbour (squared
/// distance T, float or double, and index), reduced over the tile so every lane holds it. Two chunks
/// of G edges per pass, both loads issued before either is used: the common neighbourhood (degree
/// ~16) then costs one memory round trip instead of two at G = 8.
///
/// Early stop (float pass only, stop_len2 finite): the core stores each neighbourhood shortest edge
/// first, so once the last edge of a pass is longer than sqrt(stop_len2) = 2 |q - x_v| (1 + 5e-4), so
/// is every later one, and such an x_j is farther from q than x_v by more than the float band
/// (|q - x_j| >= |x_j - x_v| - |q - x_v| > 1.001 |q - x_v|): it can be neither the move nor undecided,
/// so the rest of the neighbourhood is not read. Near queries then read one pass of the shortest edges.
template <int G, typename T, typename Tile>
__device__ __forceinline__ void scanNeighbours(const Tile& tile, const DeviceGraphView& g, float qx, float qy,
                                               float qz, std::uint32_t v, T& bd, std::uint32_t& bv,
                                               const float4& pv = make_float4(0.f, 0.f, 0.f, 0.f),
                                               float stop_len2 = INFINITY) {
  const unsigned lane = G == 1 ? 0u : tile.thread_rank();
  const std::uint32_t b = __ldg(g.offsets + v), e = __ldg(g.offsets + v + 1);
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
    if constexpr (sizeof(T) == sizeof(float)) {
      if (k0 < e) {
        const float d = dist2f(p0, qx, qy, qz);
        if (betterF(d, j0, bd, bv)) bd = d, bv = j0;
      }
      if (k1 < e) {
        const float d = dist2f(p1, qx, qy, qz);
        if (betterF(d, j1, bd, bv)) bd = d, bv = j1;
      }
      if (base + 2 * G < e && stop_len2 < INFINITY) {  // uniform: every lane sees the same edge
        float len2 = dist2f(p1, pv.x, pv.y, pv.z);     // this lane's second edge; the tile's last is lane G-1
        if constexpr (G > 1) len2 = tile.shfl(len2, G - 1);
        if (len2 > stop_len2) break;
      }
    } else {
      if (k0 < e) {
        const double d = dist2(p0, qx, qy, qz);
        if (better(d, j0, bd, bv)) bd = d, bv = j0;
      }
      if (k1 < e) {
        const double d = dist2(p1, qx, qy, qz);
        if (better(d, j1, bd, bv)) bd = d, bv = j1;
      }
    }
  }
  if constexpr (G > 1) {
#pragma unroll
    for (int o = G / 2; o > 0; o /= 2) {
      const T od = tile.shfl_xor(bd, o);
      const std::uint32_t ov = tile.shfl_xor(bv, o);
      if (od < bd || (od == bd && ov < bv)) bd = od, bv = ov;
    }
  }
}

/// The walk with G lanes of a tile scanning one neighbourhood together (G = 1: one thread per query).
/// Moves to a strictly nearer neighbour while one exists: exact (a non-nearest vertex always has a
/// strictly nearer Delaunay neighbour, docs/architecture.md) and terminating (the distance strictly
/// decreases). Every lane of the tile returns the same result.
///
/// Two shortcuts keep it exact:
///  - the safe ball: points[v].w holds r_v^2 (shrunk), r_v half the distance from x_v to its nearest
///    other vertex, which is always a Delaunay neighbour; a query strictly inside that ball is strictly
///    nearer to x_v than to any x_j (|q - x_j| >= 2 r_v - |q - x_v| > |q - x_v|): stop without a scan.
///  - float first: a scan compares float squared distances and acts on them only when they decide with
///    margin (relative kFloatTol); inside the band the neighbourhood is rescanned in double, the
///    comparison the brute force makes, so ties and far queries end exactly where they did before.
/// The reported d2 is always the double distance of the final vertex (bit-identical to brute force).
template <int G, typename Tile>
__device__ __forceinline__ std::uint32_t walkTile(const Tile& tile, const DeviceGraphView& g, float qx,
                                                  float qy, float qz, std::uint32_t v, double& d2_out,
                                                  std::uint32_t& steps) {
  float4 p = __ldg(g.points + v);
  float d2f = dist2f(p, qx, qy, qz);
  std::uint32_t s = 0;
  for (;;) {
    if (g.safe_ball && d2f < p.w) break;  // inside the safe ball (strict: w = 0 means no ball)
    float bdf = INFINITY;
    std::uint32_t bv = kInvalid;
    // Early stop only where the float distances are normal (below that the double pass decides).
    const float stop_len2 = g.shortest_first && d2f >= kFloatMin ? 4.f * d2f * 1.001f : INFINITY;
    scanNeighbours<G>(tile, g, qx, qy, qz, v, bdf, bv, p, stop_len2);
    if (d2f >= kFloatMin) {
      if (bdf < d2f * (1.f - kFloatTol)) {  // strictly nearer for certain: move
        v = bv;
        p = __ldg(g.points + v);
        d2f = dist2f(p, qx, qy, qz);
        ++s;
        continue;
      }
      if (bdf > d2f * (1.f + kFloatTol)) break;  // every neighbour strictly farther for certain
    }
    // Too close to call in float: decide as the double comparison does (only a strictly smaller
    // distance moves; a tie with the current vertex means it is already nearest).
    const double d2 = dist2(p, qx, qy, qz);
    double bd = d2;
    bv = v;
    scanNeighbours<G>(tile, g, qx, qy, qz, v, bd, bv);
    if (!(bd < d2)) break;
    v = bv;
    p = __ldg(g.points + v);
    d2f = dist2f(p, qx, qy, qz);
    ++s;
  }
  d2_out = dist2(p, qx, qy, qz);
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
}  // namespace dw
