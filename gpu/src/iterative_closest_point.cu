// dw::gpu::IterativeClosestPoint: the device-resident ICP loop (see the header for the design).
#include <algorithm>
#include <cstring>
#include <numeric>
#include <string>

#include "core/util/space_filling_curve.h"
#include "pcl_delaunay_walk/gpu/iterative_closest_point.h"
#include "pcl_delaunay_walk/gpu/rigid_transform.h"
#include "walk_device.cuh"

namespace dw {
namespace gpu {
namespace {

namespace cg = cooperative_groups;
using detail::kInvalid;

constexpr int kBlock = 256;
constexpr int kAhead = 3;  // iterations queued ahead of the GPU at most
constexpr int kSums = 17;  // count, sum q (3), sum t (3), sum q t^T (9), sum d2

/// Solver state of one source, in device memory. Composite transform: target_local = r * p + t with p
/// relative to the source centroid c; the float copy is what the correspondence kernel applies (PCL
/// likewise transforms a float copy of the source). With move_source_in_float, inc is the last step in
/// the world frame (row-major 3x4; before the first iteration the guess), which moveKernel applies to
/// the moved source, and keep_moved marks a guess that is exactly the identity (the source is copied,
/// as dw::alignIcp skips that move).
struct SourceState {
  double r[9], t[3], c[3];
  double inc[12];
  double prev_mse, mse;
  float rf[12];
  int iterations, similar, state, done, keep_moved;
  unsigned count;
};

struct SolveParams {
  double max_dist2, rotation_threshold, translation_threshold, relative_mse, absolute_mse;
  double origin[3];
  int max_iterations, max_similar, failure_after_max, float_criteria;
  unsigned min_correspondences;
};

__device__ void finish(SourceState& st, int state, unsigned* done_count, volatile unsigned* done_host) {
  st.state = state;
  st.done = 1;
  // Counted on the device; the count is then stored into mapped host memory for the host's poll. Two
  // sources finishing together may store out of order: the host then stops launching a little later.
  *done_host = atomicAdd(done_count, 1u) + 1u;
}

/// The step and PCL's convergence rules for one source, from its 17 sums (one thread).
__device__ void solveStep(SourceState& st, const double* acc, const SolveParams& prm, unsigned* done_count,
                          volatile unsigned* done_host) {
  const double n = acc[0];
  st.count = unsigned(n);
  if (n < double(prm.min_correspondences)) {  // PCL: "Not enough correspondences found"; not converged
    finish(st, int(ConvergenceState::NoCorrespondences), done_count, done_host);
    return;
  }
  // TransformationEstimationSVD on (transformed source q, target t): the step, near the identity.
  const double mq[3] = {acc[1] / n, acc[2] / n, acc[3] / n};
  const double mt[3] = {acc[4] / n, acc[5] / n, acc[6] / n};
  double cov[3][3];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) cov[a][b] = acc[7 + 3 * a + b] - n * mq[a] * mt[b];
  double rs[9];
  rotationFromCrossCovariance(cov, rs);
  double ts[3];
  for (int a = 0; a < 3; ++a)
    ts[a] = mt[a] - (rs[3 * a] * mq[0] + rs[3 * a + 1] * mq[1] + rs[3 * a + 2] * mq[2]);
  // Compose: (rs, ts) o (r, t), all in the target's local frame.
  double r[9], t[3];
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b)
      r[3 * a + b] = rs[3 * a] * st.r[b] + rs[3 * a + 1] * st.r[3 + b] + rs[3 * a + 2] * st.r[6 + b];
    t[a] = rs[3 * a] * st.t[0] + rs[3 * a + 1] * st.t[1] + rs[3 * a + 2] * st.t[2] + ts[a];
  }
  for (int k = 0; k < 9; ++k) {
    st.r[k] = r[k];
    st.rf[k] = float(r[k]);
  }
  for (int a = 0; a < 3; ++a) {
    st.t[a] = t[a];
    st.rf[9 + a] = float(t[a]);
  }
  ++st.iterations;

  // pcl::registration::DefaultConvergenceCriteria::hasConverged, rule for rule, on the world-frame
  // step: the local step conjugated by the target origin o has translation ts + (I - rs) o.
  double tw[3];
  for (int a = 0; a < 3; ++a)
    tw[a] = ts[a] + prm.origin[a] -
            (rs[3 * a] * prm.origin[0] + rs[3 * a + 1] * prm.origin[1] + rs[3 * a + 2] * prm.origin[2]);
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) st.inc[4 * a + b] = rs[3 * a + b];
    st.inc[4 * a + 3] = tw[a];
  }
  bool similar = false;
  if (st.iterations >= prm.max_iterations) {
    if (!prm.failure_after_max) {
      finish(st, int(ConvergenceState::Iterations), done_count, done_host);
      return;
    }
    st.state = int(ConvergenceState::FailureAfterMaxIterations);
  }
  double cos_angle = 0.5 * (rs[0] + rs[4] + rs[8] - 1.0);
  double translation_sqr = tw[0] * tw[0] + tw[1] * tw[1] + tw[2] * tw[2];
  if (prm.float_criteria) {  // PCL's expressions on its float Matrix4, in float (no FMA contraction)
    const float trace = __fsub_rn(__fadd_rn(__fadd_rn(float(rs[0]), float(rs[4])), float(rs[8])), 1.f);
    const float t0 = float(tw[0]), t1 = float(tw[1]), t2 = float(tw[2]);
    cos_angle = 0.5 * double(trace);
    translation_sqr = __fadd_rn(__fadd_rn(__fmul_rn(t0, t0), __fmul_rn(t1, t1)), __fmul_rn(t2, t2));
  }
  if (cos_angle >= prm.rotation_threshold && translation_sqr <= prm.translation_threshold) {
    if (st.similar >= prm.max_similar) {
      finish(st, int(ConvergenceState::Transform), done_count, done_host);
      return;
    }
    similar = true;
  }
  const double mse = acc[16] / n;
  st.mse = mse;
  if (fabs(mse - st.prev_mse) < prm.absolute_mse) {
    if (st.similar >= prm.max_similar) {
      finish(st, int(ConvergenceState::AbsMse), done_count, done_host);
      return;
    }
    similar = true;
  }
  if (fabs(mse - st.prev_mse) / st.prev_mse < prm.relative_mse) {
    if (st.similar >= prm.max_similar) {
      finish(st, int(ConvergenceState::RelMse), done_count, done_host);
      return;
    }
    similar = true;
  }
  st.similar = similar ? st.similar + 1 : 0;
  st.prev_mse = mse;
  if (st.state == int(ConvergenceState::FailureAfterMaxIterations))
    finish(st, st.state, done_count, done_host);
}

/// The correspondence half of one ICP iteration, for every source not yet done. Each block transforms
/// and walks its points and writes 17 partial sums; the last block of a source to finish (atomic
/// ticket, the classic threadfence reduction) sums that source's partials in a fixed order, so the
/// result is deterministic and the same in a batch as alone. solveKernel then takes the step.
/// Correspondences of one ICP iteration: every point of every running source is transformed by its
/// source's current estimate and walked to its exact nearest target vertex from the previous answer
/// (PNN). The same lean kernel shape as DelaunayWalk::nearest (G lanes per query, ~32 registers), so
/// as many walks are in flight as there: the reduction lives in the next kernel, because fused here it
/// raised the registers and cut the walks in flight ~3x, an iteration about 3x slower (docs/gpu.md).
constexpr int kWalkBlock = 128;  // as DelaunayWalk::nearest: 44 registers fit 11 such blocks per SM

/// x' = T x rounded to float, T row-major 3x4 in double, in dw::alignIcp's (and PCL's
/// transformPointCloud's) operation order with every product and sum rounded on its own: translation
/// first, then the x, y, z columns. The host build has no FMA, so the host loop rounds the same way.
__device__ __forceinline__ float4 movePoint(const double* t, float4 p) {
  const double c[3] = {p.x, p.y, p.z};
  float out[3];
#pragma unroll
  for (int r = 0; r < 3; ++r) {
    double v = t[4 * r + 3];
#pragma unroll
    for (int k = 0; k < 3; ++k) v = __dadd_rn(__dmul_rn(c[k], t[4 * r + k]), v);
    out[r] = __double2float_rn(v);
  }
  return make_float4(out[0], out[1], out[2], p.w);
}

/// A moved source point (world frame, float) in the target's local frame: the walk's query.
__device__ __forceinline__ float3 movedQuery(float4 m, double3 o) {
  return make_float3(__double2float_rn(__dsub_rn(m.x, o.x)), __double2float_rn(__dsub_rn(m.y, o.y)),
                     __double2float_rn(__dsub_rn(m.z, o.z)));
}

/// kMoved: the query is the moved source point (move_source_in_float), else the point transformed by
/// its source's current float estimate.
template <int G, bool kMoved>
__global__ void __launch_bounds__(kWalkBlock)
    correspondKernel(DeviceGraphView g, const float4* __restrict__ pts,
                     const std::uint32_t* __restrict__ point_source, std::uint32_t n,
                     const SourceState* __restrict__ states, double max_dist2, double3 origin,
                     std::uint32_t* __restrict__ hints, float* __restrict__ corr_d2) {
  const std::size_t i = (std::size_t(blockIdx.x) * kWalkBlock + threadIdx.x) / G;
  if (i >= n) return;  // tile-uniform: its lanes share i
  const SourceState& st = states[point_source[i]];
  if (st.done) return;
  const float4 p = pts[i];
  float qx, qy, qz;
  if constexpr (kMoved) {
    const float3 q = movedQuery(p, origin);
    qx = q.x, qy = q.y, qz = q.z;
  } else {
    qx = fmaf(st.rf[0], p.x, fmaf(st.rf[1], p.y, fmaf(st.rf[2], p.z, st.rf[9])));
    qy = fmaf(st.rf[3], p.x, fmaf(st.rf[4], p.y, fmaf(st.rf[5], p.z, st.rf[10])));
    qz = fmaf(st.rf[6], p.x, fmaf(st.rf[7], p.y, fmaf(st.rf[8], p.z, st.rf[11])));
  }
  float out = -1.f;  // rejected (no vertex, non-finite, or beyond the distance)
  std::uint32_t v = hints[i];
  if (g.num_vertices != 0 && detail::finite3(qx, qy, qz)) {
    double d2;
    std::uint32_t steps;
    const std::uint32_t start = detail::startVertex(g, qx, qy, qz, v);
    if constexpr (G == 1) {
      v = detail::walkThread(g, qx, qy, qz, start, d2, steps);
    } else {
      v = detail::walkTile<G>(cg::tiled_partition<G>(cg::this_thread_block()), g, qx, qy, qz, start, d2,
                              steps);
    }
    // PCL rejects on the float distance its search returns (distance > max_distance^2 in double).
    if (double(float(d2)) <= max_dist2) out = float(d2);
  }
  if (G == 1 || threadIdx.x % G == 0) {
    hints[i] = v;
    corr_d2[i] = out;
  }
}

/// The 17 sums of the accepted correspondences, per source: each block strides over its source's
/// points (recomputing q exactly as the walk did), reduces in double, writes a partial; the last block
/// of a source (atomic ticket, the classic threadfence reduction) sums the partials in a fixed order,
/// so the result is deterministic and the same whether the source is alone or in a batch. With `moved`,
/// pts are the moved source (world frame) and q is pts - origin in double.
__global__ void __launch_bounds__(kBlock)
    accumulateKernel(DeviceGraphView g, const float4* __restrict__ pts, bool moved, double3 origin,
                     const std::uint32_t* __restrict__ hints, const float* __restrict__ corr_d2,
                     const std::uint32_t* __restrict__ block_source, const std::uint32_t* __restrict__ meta,
                     const SourceState* __restrict__ states, double* __restrict__ partials, unsigned* tickets,
                     double* __restrict__ sums) {
  const std::uint32_t s = block_source[blockIdx.x];
  const SourceState& st = states[s];
  if (st.done) return;  // the whole block belongs to one source: uniform exit
  const std::uint32_t begin = meta[4 * s], size = meta[4 * s + 1], first_block = meta[4 * s + 2],
                      nb = meta[4 * s + 3];
  float m[12];
#pragma unroll
  for (int k = 0; k < 12; ++k) m[k] = st.rf[k];
  double acc[kSums];
#pragma unroll
  for (int k = 0; k < kSums; ++k) acc[k] = 0.0;
  for (std::uint32_t local = (blockIdx.x - first_block) * kBlock + threadIdx.x; local < size;
       local += nb * kBlock) {
    const std::uint32_t i = begin + local;
    const float d2 = corr_d2[i];
    if (!(d2 >= 0.f)) continue;
    const float4 p = pts[i];
    double x, y, z;
    if (moved) {
      x = __dsub_rn(p.x, origin.x), y = __dsub_rn(p.y, origin.y), z = __dsub_rn(p.z, origin.z);
    } else {
      x = fmaf(m[0], p.x, fmaf(m[1], p.y, fmaf(m[2], p.z, m[9])));
      y = fmaf(m[3], p.x, fmaf(m[4], p.y, fmaf(m[5], p.z, m[10])));
      z = fmaf(m[6], p.x, fmaf(m[7], p.y, fmaf(m[8], p.z, m[11])));
    }
    const float4 t = __ldg(g.points + hints[i]);
    const double tx = t.x, ty = t.y, tz = t.z;
    acc[0] += 1.0;
    acc[1] += x;
    acc[2] += y;
    acc[3] += z;
    acc[4] += tx;
    acc[5] += ty;
    acc[6] += tz;
    acc[7] += x * tx;
    acc[8] += x * ty;
    acc[9] += x * tz;
    acc[10] += y * tx;
    acc[11] += y * ty;
    acc[12] += y * tz;
    acc[13] += z * tx;
    acc[14] += z * ty;
    acc[15] += z * tz;
    acc[16] += d2;
  }
  __shared__ double part[kBlock / 32][kSums];
  const int warp = threadIdx.x / 32, lane = threadIdx.x % 32;
#pragma unroll
  for (int k = 0; k < kSums; ++k) {
#pragma unroll
    for (int o = 16; o > 0; o /= 2) acc[k] += __shfl_down_sync(0xffffffffu, acc[k], o);
    if (lane == 0) part[warp][k] = acc[k];
  }
  __syncthreads();
  __shared__ bool last;
  if (threadIdx.x < kSums) {
    double v = 0.0;
    for (int w = 0; w < kBlock / 32; ++w) v += part[w][threadIdx.x];
    partials[std::size_t(blockIdx.x) * kSums + threadIdx.x] = v;
    __threadfence();  // partials visible device-wide before the ticket says so
  }
  __syncthreads();
  if (threadIdx.x == 0) last = atomicAdd(tickets + s, 1u) == nb - 1;
  __syncthreads();
  if (!last) return;
  __threadfence();
  // Thread (row, col) sums column col of every kRows-th partial: one accumulator, coalesced loads.
  constexpr int kRows = kBlock / kSums;
  __shared__ double rsum[kRows][kSums];
  if (threadIdx.x < kRows * kSums) {
    const int col = threadIdx.x % kSums, row = threadIdx.x / kSums;
    double v = 0.0;
    for (std::uint32_t b = first_block + row; b < first_block + nb; b += kRows)
      v += __ldcg(partials + std::size_t(b) * kSums + col);  // L2, never a stale L1 line
    rsum[row][col] = v;
  }
  __syncthreads();
  if (threadIdx.x < kSums) {
    double v = 0.0;
    for (int r = 0; r < kRows; ++r) v += rsum[r][threadIdx.x];
    sums[std::size_t(s) * kSums + threadIdx.x] = v;
  }
  if (threadIdx.x == 0) tickets[s] = 0;
}

/// What one correspondence launch reads and writes.
struct CorrespondArgs {
  DeviceGraphView g;
  const float4* pts;  ///< the centred source, or the moved source when `moved`
  bool moved;
  const std::uint32_t* point_source;
  std::size_t n;
  const SourceState* states;
  double max_dist2;
  double3 origin;
  std::uint32_t* hints;
  float* corr_d2;
};

template <int G>
void launchCorrespond(const CorrespondArgs& a, cudaStream_t stream) {
  const auto blocks = unsigned((a.n * G + kWalkBlock - 1) / kWalkBlock);
  const auto n = std::uint32_t(a.n);
  if (a.moved)
    correspondKernel<G, true><<<blocks, kWalkBlock, 0, stream>>>(a.g, a.pts, a.point_source, n, a.states,
                                                                 a.max_dist2, a.origin, a.hints, a.corr_d2);
  else
    correspondKernel<G, false><<<blocks, kWalkBlock, 0, stream>>>(a.g, a.pts, a.point_source, n, a.states,
                                                                  a.max_dist2, a.origin, a.hints, a.corr_d2);
}

/// The walk kernel for the target's group size (the lanes are a template parameter of the kernel).
void launchCorrespondFor(int group_size, const CorrespondArgs& a, cudaStream_t stream) {
  switch (group_size) {
    case 1: launchCorrespond<1>(a, stream); break;
    case 2: launchCorrespond<2>(a, stream); break;
    case 8: launchCorrespond<8>(a, stream); break;
    case 16: launchCorrespond<16>(a, stream); break;
    case 32: launchCorrespond<32>(a, stream); break;
    default: launchCorrespond<4>(a, stream); break;
  }
}

/// move_source_in_float: the moved source before the first iteration, every point by its source's
/// guess (st.inc), or copied where the guess is exactly the identity.
__global__ void seedMovedKernel(const float4* __restrict__ pts, const std::uint32_t* __restrict__ point_source,
                                std::uint32_t n, const SourceState* __restrict__ states,
                                float4* __restrict__ moved) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const SourceState& st = states[point_source[i]];
  moved[i] = st.keep_moved ? pts[i] : movePoint(st.inc, pts[i]);
}

/// move_source_in_float: every point of a running source moved by the step just taken, in place.
__global__ void moveKernel(const std::uint32_t* __restrict__ point_source, std::uint32_t n,
                           const SourceState* __restrict__ states, float4* __restrict__ moved) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const SourceState& st = states[point_source[i]];
  if (!st.done) moved[i] = movePoint(st.inc, moved[i]);
}

/// The step of every source still running, one thread each. Kept out of the walk kernel: the 4x4
/// Jacobi in double needs ~100 registers, which fused into the walk cut its occupancy to one block per
/// multiprocessor and made an iteration 3-5x slower (measured, docs/gpu.md).
__global__ void solveKernel(const double* __restrict__ sums, std::uint32_t ns,
                            SourceState* __restrict__ states, SolveParams prm, unsigned* done_count,
                            volatile unsigned* done_host) {
  const std::uint32_t s = blockIdx.x * blockDim.x + threadIdx.x;
  if (s >= ns || states[s].done) return;
  double acc[kSums];
  for (int k = 0; k < kSums; ++k) acc[k] = sums[std::size_t(s) * kSums + k];
  solveStep(states[s], acc, prm, done_count, done_host);
}

/// A source with no points has no blocks: its sums are zero (no correspondences).
__global__ void emptySourcesKernel(const std::uint32_t* __restrict__ meta, std::uint32_t ns,
                                   double* __restrict__ sums) {
  const std::uint32_t s = blockIdx.x * blockDim.x + threadIdx.x;
  if (s >= ns || meta[4 * s + 3] != 0) return;
  for (int k = 0; k < kSums; ++k) sums[std::size_t(s) * kSums + k] = 0.0;
}

/// First starts of an align: the warm start of each point's caller index where one is kept.
__global__ void gatherHintsKernel(const std::uint32_t* __restrict__ input_index, std::uint32_t n,
                                  const std::uint32_t* __restrict__ warm, std::uint32_t warm_valid,
                                  std::uint32_t* __restrict__ hints) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const std::uint32_t c = input_index[i];
  hints[i] = c < warm_valid ? warm[c] : kInvalid;
}

/// Last vertices of an align, kept per caller index for the next one.
__global__ void scatterHintsKernel(const std::uint32_t* __restrict__ input_index, std::uint32_t n,
                                   const std::uint32_t* __restrict__ hints,
                                   std::uint32_t* __restrict__ warm) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) warm[input_index[i]] = hints[i];
}

}  // namespace

const char* toString(ConvergenceState s) {
  switch (s) {
    case ConvergenceState::NotConverged: return "not converged";
    case ConvergenceState::Iterations: return "iterations";
    case ConvergenceState::Transform: return "transform";
    case ConvergenceState::AbsMse: return "absolute MSE";
    case ConvergenceState::RelMse: return "relative MSE";
    case ConvergenceState::NoCorrespondences: return "no correspondences";
    case ConvergenceState::FailureAfterMaxIterations: return "failure after max iterations";
  }
  return "unknown";
}

namespace {

/// A source's state before its first iteration: the guess in the device frame, where points are
/// stored relative to the source centroid c and the target relative to its origin o.
SourceState initialState(const Matrix4d& g, const double c[3], const std::array<double, 3>& o) {
  for (double x : g)
    if (!std::isfinite(x)) throw dw::Error("dw::gpu::IterativeClosestPoint: non-finite initial guess");
  SourceState st;
  std::memset(&st, 0, sizeof st);
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) st.r[3 * a + b] = g[4 * a + b];
    // target_local = G_R (p + c) + G_t - o
    st.t[a] = g[4 * a] * c[0] + g[4 * a + 1] * c[1] + g[4 * a + 2] * c[2] + g[4 * a + 3] - o[a];
    st.c[a] = c[a];
  }
  for (int k = 0; k < 9; ++k) st.rf[k] = float(st.r[k]);
  for (int a = 0; a < 3; ++a) st.rf[9 + a] = float(st.t[a]);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 4; ++b) st.inc[4 * a + b] = g[4 * a + b];
  st.keep_moved = g == identityMatrix4d() ? 1 : 0;
  st.prev_mse = std::numeric_limits<double>::max();
  st.state = int(ConvergenceState::NotConverged);
  return st;
}

/// PCL's settings as the solve kernel reads them (thresholds resolved, the target origin for the
/// world-frame criteria).
SolveParams solveParams(const IcpParameters& p, const std::array<double, 3>& o) {
  SolveParams prm{};
  prm.max_dist2 = p.max_correspondence_distance * p.max_correspondence_distance;
  prm.rotation_threshold = p.transformation_rotation_epsilon > 0 ? p.transformation_rotation_epsilon
                                                                 : 1.0 - p.transformation_epsilon;
  prm.translation_threshold = p.transformation_epsilon;
  prm.relative_mse = p.euclidean_fitness_epsilon;
  prm.absolute_mse = p.mse_threshold_absolute;
  for (int a = 0; a < 3; ++a) prm.origin[a] = o[a];
  prm.max_iterations = p.max_iterations;
  prm.max_similar = p.max_iterations_similar_transforms;
  prm.failure_after_max = p.failure_after_max_iterations ? 1 : 0;
  prm.float_criteria = p.float_transform_criteria ? 1 : 0;
  prm.min_correspondences = p.min_number_correspondences;
  return prm;
}

/// A source's final state as PCL reports it: the world-frame transform, iterations, state, MSE.
IcpResult resultOf(const SourceState& st, const std::array<double, 3>& o) {
  IcpResult r;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) r.transformation[4 * a + b] = st.r[3 * a + b];
    // world: target_w = r (p_w - c) + t + o
    r.transformation[4 * a + 3] =
        st.t[a] + o[a] - (st.r[3 * a] * st.c[0] + st.r[3 * a + 1] * st.c[1] + st.r[3 * a + 2] * st.c[2]);
  }
  r.transformation[12] = r.transformation[13] = r.transformation[14] = 0.0;
  r.transformation[15] = 1.0;
  r.iterations = st.iterations;
  r.state = static_cast<ConvergenceState>(st.state);
  r.converged = r.state != ConvergenceState::NotConverged && r.state != ConvergenceState::NoCorrespondences &&
                r.state != ConvergenceState::FailureAfterMaxIterations;
  r.mse = st.mse;
  r.correspondences = st.count;
  return r;
}

}  // namespace

IterativeClosestPoint::IterativeClosestPoint(DelaunayWalk::ConstPtr target) : target_(std::move(target)) {
  if (!target_) throw dw::Error("dw::gpu::IterativeClosestPoint: null target");
  checkCuda(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "cudaStreamCreate");
  for (auto& e : events_) checkCuda(cudaEventCreateWithFlags(&e, cudaEventDisableTiming), "cudaEventCreate");
  void* p = nullptr;
  checkCuda(cudaHostAlloc(&p, sizeof(unsigned), cudaHostAllocMapped), "cudaHostAlloc");
  done_host_ = static_cast<unsigned*>(p);
  *done_host_ = 0;
  checkCuda(cudaHostGetDevicePointer(reinterpret_cast<void**>(&done_host_dev_), p, 0),
            "cudaHostGetDevicePointer");
  done_count_.create(1);
}

IterativeClosestPoint::~IterativeClosestPoint() {
  if (stream_) cudaStreamSynchronize(stream_);
  if (done_host_) cudaFreeHost(done_host_);
  for (auto& e : events_)
    if (e) cudaEventDestroy(e);
  if (stream_) cudaStreamDestroy(stream_);
}

void IterativeClosestPoint::setParameters(const IcpParameters& p) {
  if (!(p.max_correspondence_distance >= 0.0))
    throw dw::Error("dw::gpu::IterativeClosestPoint: max_correspondence_distance must be >= 0");
  if (std::isnan(p.transformation_epsilon) || std::isnan(p.transformation_rotation_epsilon) ||
      std::isnan(p.euclidean_fitness_epsilon) || std::isnan(p.mse_threshold_absolute))
    throw dw::Error("dw::gpu::IterativeClosestPoint: NaN threshold");
  params_ = p;
}

void IterativeClosestPoint::clearSources() {
  sources_.clear();
  host_points_.clear();
  host_input_index_.clear();
  total_inputs_ = 0;
  dirty_ = true;
}

void IterativeClosestPoint::setInputSource(const dw::PointView& source) {
  clearSources();
  addSource(source);
}

namespace {

/// A stable least-significant-digit counting sort of `order` by 30-bit keys, three 10-bit digits.
/// Linear, where a comparison sort of a 120k-point scan cost several milliseconds of the frame.
void sortByKey30(const std::vector<std::uint32_t>& key, std::vector<std::uint32_t>& order) {
  std::vector<std::uint32_t> tmp(order.size());
  std::vector<std::uint32_t> count(1025);
  for (int shift = 0; shift < 30; shift += 10) {
    std::fill(count.begin(), count.end(), 0u);
    for (std::uint32_t i : order) ++count[((key[i] >> shift) & 1023u) + 1];
    for (std::size_t d = 1; d < count.size(); ++d) count[d] += count[d - 1];
    for (std::uint32_t i : order) tmp[count[(key[i] >> shift) & 1023u]++] = i;
    order.swap(tmp);
  }
}

}  // namespace

std::size_t IterativeClosestPoint::addSource(const dw::PointView& source) {
  if (total_inputs_ + source.size >= kInvalid)
    throw dw::Error("dw::gpu::IterativeClosestPoint: sources too large for 32-bit device indices");
  HostSource hs;
  hs.begin = host_points_.size();
  hs.input_begin = total_inputs_;
  // Moved in float, the source keeps the caller's float coordinates (centroid 0), as dw::alignIcp does.
  hs.moved = params_.move_source_in_float;
  std::vector<std::uint32_t> kept;  // source index of each finite point
  kept.reserve(source.size);
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, sum[3] = {0, 0, 0};
  for (std::size_t i = 0; i < source.size; ++i) {
    const auto p = source[i];
    if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) continue;
    for (int a = 0; a < 3; ++a) {
      lo[a] = kept.empty() ? p[a] : std::min(lo[a], p[a]);
      hi[a] = kept.empty() ? p[a] : std::max(hi[a], p[a]);
      sum[a] += p[a];
    }
    kept.push_back(std::uint32_t(i));
  }
  hs.size = kept.size();
  total_inputs_ += source.size;
  if (!kept.empty() && !hs.moved)
    for (int a = 0; a < 3; ++a) hs.centroid[a] = sum[a] / double(kept.size());
  // Morton order: consecutive queries then walk through neighbouring vertices (shared cache lines),
  // the same reason the graph's vertices are stored in this order. 1024 cells per axis of the scan's
  // extent (~10 cm at 100 m) order the walks as well as finer keys; equal keys keep the input order.
  std::vector<std::uint32_t> key(source.size, 0u);
  const double ext = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-300});
  for (std::uint32_t i : kept) {
    const auto p = source[i];
    std::uint32_t c[3];
    for (int a = 0; a < 3; ++a) c[a] = std::uint32_t(std::min(1023.0, (p[a] - lo[a]) / ext * 1024.0));
    key[i] = std::uint32_t(dw::mortonKey(c[0], c[1], c[2]));
  }
  sortByKey30(key, kept);
  host_points_.reserve(host_points_.size() + kept.size());
  host_input_index_.reserve(host_input_index_.size() + kept.size());
  for (std::uint32_t i : kept) {
    const auto p = source[i];
    host_points_.push_back(make_float4(float(p[0] - hs.centroid[0]), float(p[1] - hs.centroid[1]),
                                       float(p[2] - hs.centroid[2]), 0.f));
    host_input_index_.push_back(std::uint32_t(hs.input_begin + i));
  }
  sources_.push_back(hs);
  dirty_ = true;
  return sources_.size() - 1;
}

void IterativeClosestPoint::uploadLayout() {
  // Blocks per source: enough to fill the GPU once (every resident block walks batches of points in
  // turn), not one per batch, so that the last block sums few partials.
  int per_sm = 0, sms = 0, dev = 0;
  checkCuda(cudaGetDevice(&dev), "cudaGetDevice");
  checkCuda(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev), "cudaDeviceGetAttribute");
  checkCuda(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, accumulateKernel, kBlock, 0), "occupancy");
  const std::size_t cap = std::size_t(std::max(1, per_sm * sms));
  std::vector<std::uint32_t> block_source, meta, point_source;
  for (std::size_t s = 0; s < sources_.size(); ++s) {
    const std::size_t batches = (sources_[s].size + kBlock - 1) / kBlock;
    const auto nb = std::uint32_t(std::min(batches, cap));
    meta.push_back(std::uint32_t(sources_[s].begin));
    meta.push_back(std::uint32_t(sources_[s].size));
    meta.push_back(std::uint32_t(block_source.size()));
    meta.push_back(nb);
    block_source.insert(block_source.end(), nb, std::uint32_t(s));
    point_source.insert(point_source.end(), sources_[s].size, std::uint32_t(s));
  }
  num_blocks_ = std::uint32_t(block_source.size());
  const std::size_t n = host_points_.size();
  // Through page-locked staging, asynchronously on the ICP's stream: the copies queue ahead of the
  // iterations instead of blocking the host. The staging is rewritten only here, and every earlier
  // copy from it has completed by then (align waits for its stream before it returns).
  checkCuda(cudaStreamSynchronize(stream_), "ICP: staging");
  stage_points_.create(n);
  std::copy(host_points_.begin(), host_points_.end(), stage_points_.data());
  const std::size_t ni = point_source.size() + block_source.size() + meta.size() + n;
  stage_indices_.create(ni);
  std::uint32_t* at = stage_indices_.data();
  auto stage = [&](DeviceBuffer<std::uint32_t>& dev, const std::uint32_t* host, std::size_t count) {
    std::copy(host, host + count, at);
    dev.create(count);
    if (count)
      checkCuda(
          cudaMemcpyAsync(dev.ptr(), at, count * sizeof(std::uint32_t), cudaMemcpyHostToDevice, stream_),
          "ICP: upload indices");
    at += count;
  };
  points_.create(n);
  if (n)
    checkCuda(cudaMemcpyAsync(points_.ptr(), stage_points_.data(), n * sizeof(float4), cudaMemcpyHostToDevice,
                              stream_),
              "ICP: upload points");
  stage(point_source_, point_source.data(), point_source.size());
  stage(block_source_, block_source.data(), block_source.size());
  stage(source_meta_, meta.data(), meta.size());
  stage(input_index_, host_input_index_.data(), n);
  hints_.create(n);
  corr_d2_.create(n);
  moved_.create(params_.move_source_in_float ? n : 0);
  partials_.create(std::max<std::size_t>(1, block_source.size()) * kSums);
  states_.create(sources_.size() * sizeof(SourceState));
  tickets_.create(sources_.size());
  sums_.create(sources_.size() * kSums);
  dirty_ = false;
}

IcpResult IterativeClosestPoint::align(const Matrix4d& guess) {
  if (sources_.size() != 1)
    throw dw::Error(
        "dw::gpu::IterativeClosestPoint::align: needs exactly one source (use alignAll for a batch)");
  return alignAll({guess}).front();
}

std::vector<IcpResult> IterativeClosestPoint::alignAll(const std::vector<Matrix4d>& guesses) {
  const std::size_t ns = sources_.size();
  if (ns == 0) throw dw::Error("dw::gpu::IterativeClosestPoint: no source set");
  if (!guesses.empty() && guesses.size() != ns)
    throw dw::Error("dw::gpu::IterativeClosestPoint::alignAll: one guess per source, or none");
  const bool moved = params_.move_source_in_float;
  for (const HostSource& hs : sources_)
    if (hs.moved != moved)
      throw dw::Error(
          "dw::gpu::IterativeClosestPoint: move_source_in_float changed after the sources were added; "
          "add them again");
  if (dirty_) uploadLayout();
  const auto& o = target_->origin();

  std::vector<SourceState> init(ns);
  for (std::size_t s = 0; s < ns; ++s)
    init[s] = initialState(guesses.empty() ? identityMatrix4d() : guesses[s], sources_[s].centroid, o);
  checkCuda(
      cudaMemcpyAsync(states_.ptr(), init.data(), ns * sizeof(SourceState), cudaMemcpyHostToDevice, stream_),
      "ICP: upload state");
  seedHints();
  const std::size_t n = host_points_.size();
  if (moved && n) {
    seedMovedKernel<<<unsigned((n + 255) / 256), 256, 0, stream_>>>(
        points_.ptr(), point_source_.ptr(), std::uint32_t(n), reinterpret_cast<const SourceState*>(states_.ptr()),
        moved_.ptr());
    checkCuda(cudaGetLastError(), "ICP: seed the moved source");
  }
  checkCuda(cudaMemsetAsync(done_count_.ptr(), 0, sizeof(unsigned), stream_), "ICP: reset");
  checkCuda(cudaMemsetAsync(tickets_.ptr(), 0, tickets_.size() * sizeof(unsigned), stream_),
            "ICP: reset tickets");
  runIterations();
  if (warm_start_) keepHints();

  std::vector<SourceState> fin(ns);
  checkCuda(
      cudaMemcpyAsync(fin.data(), states_.ptr(), ns * sizeof(SourceState), cudaMemcpyDeviceToHost, stream_),
      "ICP: download state");
  checkCuda(cudaStreamSynchronize(stream_), "ICP: align");
  std::vector<IcpResult> out(ns);
  for (std::size_t s = 0; s < ns; ++s) out[s] = resultOf(fin[s], o);
  return out;
}

void IterativeClosestPoint::seedHints() {
  const std::size_t n = host_points_.size();
  if (!warm_start_ || warm_valid_ == 0 || n == 0) {
    checkCuda(cudaMemsetAsync(hints_.ptr(), 0xff, n * sizeof(std::uint32_t), stream_), "ICP: reset hints");
    return;
  }
  gatherHintsKernel<<<unsigned((n + 255) / 256), 256, 0, stream_>>>(
      input_index_.ptr(), std::uint32_t(n), warm_hints_.ptr(), std::uint32_t(warm_valid_), hints_.ptr());
  checkCuda(cudaGetLastError(), "ICP: warm starts");
}

void IterativeClosestPoint::keepHints() {
  const std::size_t n = host_points_.size();
  if (total_inputs_ > warm_hints_.size()) {
    // Rare (a larger source than ever before): a new array, the kept starts copied, the rest "none".
    // The wait lets the old array go while nothing reads it.
    DeviceBuffer<std::uint32_t> grown(total_inputs_);
    checkCuda(cudaMemsetAsync(grown.ptr(), 0xff, total_inputs_ * sizeof(std::uint32_t), stream_),
              "ICP: warm starts");
    if (warm_valid_)
      checkCuda(cudaMemcpyAsync(grown.ptr(), warm_hints_.ptr(), warm_valid_ * sizeof(std::uint32_t),
                                cudaMemcpyDeviceToDevice, stream_),
                "ICP: warm starts");
    checkCuda(cudaStreamSynchronize(stream_), "ICP: warm starts");
    warm_hints_ = std::move(grown);
  } else if (total_inputs_ > warm_valid_) {
    checkCuda(cudaMemsetAsync(warm_hints_.ptr() + warm_valid_, 0xff,
                              (total_inputs_ - warm_valid_) * sizeof(std::uint32_t), stream_),
              "ICP: warm starts");
  }
  warm_valid_ = std::max(warm_valid_, total_inputs_);
  if (n == 0) return;
  scatterHintsKernel<<<unsigned((n + 255) / 256), 256, 0, stream_>>>(input_index_.ptr(), std::uint32_t(n),
                                                                     hints_.ptr(), warm_hints_.ptr());
  checkCuda(cudaGetLastError(), "ICP: keep warm starts");
}

void IterativeClosestPoint::runIterations() {
  const std::size_t ns = sources_.size();
  const SolveParams prm = solveParams(params_, target_->origin());
  auto* state_ptr = reinterpret_cast<SourceState*>(states_.ptr());
  const bool moved = params_.move_source_in_float;
  const std::size_t n = host_points_.size();
  const float4* pts = moved ? moved_.ptr() : points_.ptr();
  const double3 origin = make_double3(target_->origin()[0], target_->origin()[1], target_->origin()[2]);
  volatile unsigned* done_flag = done_host_;
  *done_flag = 0;
  emptySourcesKernel<<<unsigned((ns + 127) / 128), 128, 0, stream_>>>(source_meta_.ptr(), std::uint32_t(ns),
                                                                      sums_.ptr());
  checkCuda(cudaGetLastError(), "ICP: empty sources");
  // PCL's loop is do-while: at least one iteration runs whatever max_iterations says.
  const int launches = std::max(1, params_.max_iterations);
  for (int it = 0; it < launches; ++it) {
    // Stop launching once every source is done: the solving thread writes the count straight into
    // mapped host memory, so reading it costs no copy and no synchronisation.
    if (*done_flag >= ns) break;
    // Keep at most kAhead iterations queued: the GPU never starves, and after convergence only a few
    // launches that return at once are left behind. This waits on the host only, never the device.
    if (it >= kAhead) checkCuda(cudaEventSynchronize(events_[it % kAhead]), "ICP: throttle");
    if (*done_flag >= ns) break;
    if (num_blocks_ > 0) {
      const CorrespondArgs a{target_->view(), pts, moved,         point_source_.ptr(), n,
                             state_ptr,       prm.max_dist2, origin, hints_.ptr(),       corr_d2_.ptr()};
      launchCorrespondFor(target_->groupSize(), a, stream_);
      accumulateKernel<<<num_blocks_, kBlock, 0, stream_>>>(
          a.g, pts, moved, origin, hints_.ptr(), corr_d2_.ptr(), block_source_.ptr(), source_meta_.ptr(),
          state_ptr, partials_.ptr(), tickets_.ptr(), sums_.ptr());
    }
    solveKernel<<<unsigned((ns + 31) / 32), 32, 0, stream_>>>(sums_.ptr(), std::uint32_t(ns), state_ptr, prm,
                                                              done_count_.ptr(), done_host_dev_);
    if (moved && n)
      moveKernel<<<unsigned((n + 255) / 256), 256, 0, stream_>>>(point_source_.ptr(), std::uint32_t(n), state_ptr,
                                                                  moved_.ptr());
    checkCuda(cudaGetLastError(), "ICP: iteration launch");
    checkCuda(cudaEventRecord(events_[it % kAhead], stream_), "ICP: event");
  }
}

}  // namespace gpu
}  // namespace dw
