// dw::gpu::DelaunayWalk: graph upload, start grid, batch NN / kNN / radius and the brute-force reference.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "pcl_delaunay_walk/gpu/delaunay_walk.h"
#include "walk_device.cuh"

namespace dw {
namespace gpu {
namespace {

namespace cg = cooperative_groups;
using detail::kInvalid;

constexpr int kBlock = 256;

unsigned blocksFor(std::size_t threads) {
  return unsigned((threads + kBlock - 1) / kBlock);
}

void checkLaunch(const char* what) {
  checkCuda(cudaGetLastError(), what);
}

// The walk kernels use 44 registers: 128-thread blocks fit 11 per SM (44 warps) where 256-thread ones
// fit 5 (40 warps), and resident walks are what hide the gathers' latency.
constexpr int kWalkBlock = 128;

template <int G>
__global__ void __launch_bounds__(kWalkBlock)
    nearestKernel(DeviceGraphView g, const float4* __restrict__ queries, std::uint32_t n,
                  const std::uint32_t* __restrict__ hints, std::uint32_t* __restrict__ vertices,
                  float* __restrict__ dist2, std::uint32_t* __restrict__ steps) {
  const std::size_t qi = (std::size_t(blockIdx.x) * kWalkBlock + threadIdx.x) / G;
  if (qi >= n) return;  // a whole tile leaves together: its lanes share qi
  const float4 q = queries[qi];
  std::uint32_t v = kInvalid, s = 0;
  double d2 = INFINITY;
  if (g.num_vertices != 0 && detail::finite3(q.x, q.y, q.z)) {
    const std::uint32_t start = detail::startVertex(g, q.x, q.y, q.z, hints ? hints[qi] : kInvalid);
    if constexpr (G == 1) {
      v = detail::walkThread(g, q.x, q.y, q.z, start, d2, s);
    } else {
      const auto tile = cg::tiled_partition<G>(cg::this_thread_block());
      v = detail::walkTile<G>(tile, g, q.x, q.y, q.z, start, d2, s);
    }
  }
  if (G == 1 || threadIdx.x % G == 0) {
    vertices[qi] = v;
    dist2[qi] = float(d2);
    if (steps) steps[qi] = s;
  }
}

/// Seeds of one grid level: the exact NN of each cell centre, walked from the parent level's seed.
__global__ void gridSeedKernel(DeviceGraphView g, int dx, int dy, int dz, float ox, float oy, float oz,
                               float hx, float hy, float hz, const std::uint32_t* parent, int pdx, int pdy,
                               int ratio, std::uint32_t* seeds) {
  const std::size_t c = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  const std::size_t total = std::size_t(dx) * dy * dz;
  if (c >= total) return;
  const int ix = int(c % dx), iy = int((c / dx) % dy), iz = int(c / (std::size_t(dx) * dy));
  std::uint32_t start = 0;
  if (parent) start = parent[(std::size_t(iz / ratio) * pdy + iy / ratio) * pdx + ix / ratio];
  double d2;
  std::uint32_t s;
  seeds[c] = detail::walkThread(g, ox + (ix + 0.5f) * hx, oy + (iy + 0.5f) * hy, oz + (iz + 0.5f) * hz, start,
                                d2, s);
}

/// Brute force: each thread one query, vertices streamed through shared memory in tiles.
__global__ void __launch_bounds__(kBlock)
    bruteForceKernel(const float4* __restrict__ points, std::uint32_t nv, const float4* __restrict__ queries,
                     std::uint32_t n, std::uint32_t* __restrict__ vertices, float* __restrict__ dist2) {
  __shared__ float4 tile[kBlock];
  const std::size_t qi = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  float4 q = qi < n ? queries[qi] : make_float4(0.f, 0.f, 0.f, 0.f);
  const bool valid = qi < n && detail::finite3(q.x, q.y, q.z);
  double bd = INFINITY;
  std::uint32_t bv = kInvalid;
  for (std::uint32_t base = 0; base < nv; base += kBlock) {
    __syncthreads();
    if (base + threadIdx.x < nv) tile[threadIdx.x] = points[base + threadIdx.x];
    __syncthreads();
    const std::uint32_t m = min(std::uint32_t(kBlock), nv - base);
    if (valid) {
      for (std::uint32_t t = 0; t < m; ++t) {
        const double d = detail::dist2(tile[t], q.x, q.y, q.z);
        if (d < bd) {  // ascending scan: strict < keeps the smaller index on ties
          bd = d;
          bv = base + t;
        }
      }
    }
  }
  if (qi < n) {
    vertices[qi] = bv;
    dist2[qi] = bv == kInvalid ? INFINITY : float(bd);
  }
}

/// Exact kNN / bounded radius by best-first expansion from the NN (docs/architecture.md, "Why the searches
/// are exact"), one thread per query. State is bounded without a visited set: F (expanded vertices) and C
/// (candidates, sorted descending so the nearest pops from the back) each hold at most CAP vertices. A
/// candidate is dropped only when at least k inputs are already known to be nearer, so it can never be one of
/// the k; one dropped and met again is simply reconsidered.
template <int CAP>
__global__ void __launch_bounds__(128)
    expandKernel(DeviceGraphView g, const float4* __restrict__ queries, std::uint32_t n,
                 const std::uint32_t* __restrict__ hints, unsigned k, double r2,
                 std::uint32_t* __restrict__ out_idx, float* __restrict__ out_d2,
                 std::uint32_t* __restrict__ counts) {
  const std::size_t qi = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (qi >= n) return;
  std::uint32_t* row_idx = out_idx + qi * k;
  float* row_d2 = out_d2 + qi * k;
  for (unsigned t = 0; t < k; ++t) {
    row_idx[t] = kInvalid;
    row_d2[t] = INFINITY;
  }
  const float4 q = queries[qi];
  unsigned emitted = 0;
  if (g.num_vertices != 0 && detail::finite3(q.x, q.y, q.z)) {
    double d0;
    std::uint32_t s;
    const std::uint32_t v0 = detail::walkThread(
        g, q.x, q.y, q.z, detail::startVertex(g, q.x, q.y, q.z, hints ? hints[qi] : kInvalid), d0, s);
    double cd[CAP];
    std::uint32_t cv[CAP];
    std::uint32_t fv[CAP];
    int nc = 0, nf = 0;
    if (d0 <= r2) {
      cd[0] = d0;
      cv[0] = v0;
      nc = 1;
    }
    while (nc > 0 && emitted < k) {
      --nc;
      const double d = cd[nc];
      const std::uint32_t v = cv[nc];
      fv[nf++] = v;
      for (std::uint32_t o = g.originals_offsets[v], oe = g.originals_offsets[v + 1]; o < oe && emitted < k;
           ++o) {
        row_idx[emitted] = g.originals[o];
        row_d2[emitted] = float(d);
        ++emitted;
      }
      if (emitted >= k) break;
      const int limit = int(k - emitted);  // vertices still needed at most (each holds >= 1 input)
      if (nc > limit) {                    // drop the worst: k inputs are known nearer than them
        const int drop = nc - limit;
        for (int t = 0; t < limit; ++t) {
          cd[t] = cd[t + drop];
          cv[t] = cv[t + drop];
        }
        nc = limit;
      }
      for (std::uint32_t e = g.offsets[v], ee = g.offsets[v + 1]; e < ee; ++e) {
        const std::uint32_t w = g.neighbours[e];
        const double dw = detail::dist2(g.points[w], q.x, q.y, q.z);
        if (!(dw <= r2)) continue;
        if (nc == limit && !detail::better(dw, w, cd[0], cv[0])) continue;
        bool seen = false;
        for (int t = 0; t < nf && !seen; ++t) seen = fv[t] == w;
        for (int t = 0; t < nc && !seen; ++t) seen = cv[t] == w;
        if (seen) continue;
        int pos;
        if (nc == limit) {  // replace the worst (index 0): farther entries slide down to make room
          pos = 0;
          while (pos + 1 < nc && detail::better(dw, w, cd[pos + 1], cv[pos + 1])) {
            cd[pos] = cd[pos + 1];
            cv[pos] = cv[pos + 1];
            ++pos;
          }
        } else {  // insert from the nearest end: entries nearer than w move one step up
          pos = nc;
          while (pos > 0 && detail::better(cd[pos - 1], cv[pos - 1], dw, w)) {
            cd[pos] = cd[pos - 1];
            cv[pos] = cv[pos - 1];
            --pos;
          }
          ++nc;
        }
        cd[pos] = dw;
        cv[pos] = w;
      }
    }
  }
  counts[qi] = emitted;
}

__global__ void edgePointsKernel(const float4* __restrict__ points, const std::uint32_t* __restrict__ nbr,
                                 std::size_t m, float4* __restrict__ out) {
  const std::size_t e = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  if (e >= m) return;
  const std::uint32_t j = nbr[e];
  const float4 p = points[j];
  out[e] = make_float4(p.x, p.y, p.z, __uint_as_float(j));
}

__global__ void mapKernel(const std::uint32_t* __restrict__ table, std::uint32_t table_size,
                          std::uint32_t* __restrict__ v, std::size_t n) {
  const std::size_t i = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  if (i < n && v[i] < table_size) v[i] = table[v[i]];
}

template <int G>
void launchNearest(const DeviceGraphView& g, const float4* q, std::size_t n, const std::uint32_t* hints,
                   std::uint32_t* vertices, float* dist2, std::uint32_t* steps, cudaStream_t stream) {
  nearestKernel<G><<<unsigned((n * G + kWalkBlock - 1) / kWalkBlock), kWalkBlock, 0, stream>>>(
      g, q, std::uint32_t(n), hints, vertices, dist2, steps);
}

}  // namespace

void DelaunayWalk::setGraph(const dw::DelaunayGraph& graph, double cells_per_vertex) {
  const std::size_t nv = graph.numVertices();
  if (nv >= kInvalid || graph.numDirectedEdges() >= kInvalid || graph.numInputPoints() >= kInvalid)
    throw dw::Error("dw::gpu::DelaunayWalk: graph too large for 32-bit device indices");
  if (graph.offsets.size() != nv + 1 || graph.originals_offsets.size() != nv + 1 ||
      (nv && graph.offsets.back() != graph.edges.size()))
    throw dw::Error(
        "dw::gpu::DelaunayWalk: graph CSR arrays are inconsistent (call DelaunayGraph::validate)");
  if (!(cells_per_vertex > 0.0) || !std::isfinite(cells_per_vertex))
    throw dw::Error("dw::gpu::DelaunayWalk: cells_per_vertex must be positive and finite");

  std::vector<std::uint32_t> nbr(graph.edges.size());
  for (std::size_t e = 0; e < nbr.size(); ++e) {
    nbr[e] = graph.edges[e].j;
    if (nbr[e] >= nv)
      throw dw::Error("dw::gpu::DelaunayWalk: edge " + std::to_string(e) + " points past the vertices");
  }
  // w = the safe-ball radius^2 of the walk (walk_device.cuh): a quarter of the squared distance to the
  // nearest neighbour, from the float vertices in double (not from the edge records' rounded m), shrunk
  // by 1e-5, far more than the float rounding of w and of the walk's float distance (3e-7). Balls too
  // small for float precision stay 0, which disables the test (it is strict).
  // Also checked here: whether every neighbourhood is shortest edge first (the core's order, up to the
  // float rounding of m), which the walk's early stop relies on; a graph not in that order still
  // walks exactly, only without the early stop.
  std::vector<float4> pts(nv);
  bool shortest_first = true;
  for (std::size_t v = 0; v < nv; ++v) {
    const dw::Vec3f& x = graph.points[v];
    double nn2 = INFINITY, prev2 = 0.0;
    for (std::uint32_t e = graph.offsets[v]; e < graph.offsets[v + 1]; ++e) {
      const dw::Vec3f& y = graph.points[nbr[e]];
      const double dx = double(y.x) - x.x, dy = double(y.y) - x.y, dz = double(y.z) - x.z;
      const double len2 = dx * dx + dy * dy + dz * dz;
      nn2 = std::min(nn2, len2);
      if (len2 < prev2 * (1.0 - 1e-5)) shortest_first = false;
      prev2 = len2;
    }
    const double r2 = 0.25 * nn2 * (1.0 - 1e-5);
    const float w = static_cast<float>(r2);  // inf when r^2 leaves float's range: then no ball
    pts[v] = make_float4(x.x, x.y, x.z, std::isfinite(w) && r2 >= 1e-30 && double(w) < 0.25 * nn2 ? w : 0.f);
  }
  vertex_to_input_.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    if (graph.originals_offsets[v] >= graph.originals_offsets[v + 1] ||
        graph.originals_offsets[v + 1] > graph.originals.size())
      throw dw::Error("dw::gpu::DelaunayWalk: vertex " + std::to_string(v) + " has no original input index");
    vertex_to_input_[v] = graph.representative(dw::index_t(v));
  }

  points_.upload(pts);
  offsets_.upload(graph.offsets);
  neighbours_.upload(nbr);
  originals_offsets_.upload(graph.originals_offsets);
  originals_.upload(graph.originals);
  vertex_to_input_dev_.upload(vertex_to_input_);
  origin_ = graph.origin;
  num_inputs_ = graph.numInputPoints();

  const bool inline_positions = auto_inline_ ? defaultInlineNeighbourPositions(nbr.size())
                                             : view_.edge_points != nullptr;  // a chosen layout stays
  view_ = DeviceGraphView{};
  view_.points = points_.ptr();
  view_.offsets = offsets_.ptr();
  view_.neighbours = neighbours_.ptr();
  view_.originals_offsets = originals_offsets_.ptr();
  view_.originals = originals_.ptr();
  view_.num_vertices = std::uint32_t(nv);
  view_.shortest_first = shortest_first;
  grid_seeds_.release();
  if (auto_group_size_) group_size_ = defaultGroupSize(nv);
  if (nv > 1) buildStartGrid(graph, cells_per_vertex);
  checkCuda(cudaDeviceSynchronize(), "DelaunayWalk::setGraph");
  applyInlineNeighbourPositions(inline_positions);
  setSafeBallTest(safe_ball_);
}

void DelaunayWalk::buildStartGrid(const dw::DelaunayGraph& graph, double cells_per_vertex) {
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (const auto& p : graph.points) {
    const float c[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], c[a]);
      hi[a] = std::max(hi[a], c[a]);
    }
  }
  double ext[3];
  for (int a = 0; a < 3; ++a) ext[a] = double(hi[a]) - double(lo[a]);
  const double max_ext = std::max({ext[0], ext[1], ext[2]});
  if (!(max_ext > 0.0)) return;  // all vertices coincide in float: vertex 0 is as good a start as any
  // Cell edge h so that the number of cells is about cells_per_vertex * n; flat or thin sets get one
  // cell across their thin axes (found by bisection on h, since dims depend on h stepwise).
  const double target = std::min(4.0e6, std::max(1.0, cells_per_vertex * double(graph.numVertices())));
  auto cellsFor = [&](double h, int* dims) {
    double total = 1.0;
    for (int a = 0; a < 3; ++a) {
      dims[a] = int(std::min(1024.0, std::max(1.0, std::ceil(ext[a] / h))));
      total *= dims[a];
    }
    return total;
  };
  int dims[3];
  double h_lo = max_ext / 1024.0, h_hi = max_ext;
  for (int it = 0; it < 60; ++it) {
    const double h = std::sqrt(h_lo * h_hi);
    (cellsFor(h, dims) > target ? h_lo : h_hi) = h;
  }
  cellsFor(h_hi, dims);
  const float h[3] = {float(ext[0] / dims[0]), float(ext[1] / dims[1]), float(ext[2] / dims[2])};
  for (int a = 0; a < 3; ++a) {
    view_.grid_min[a] = lo[a];
    view_.grid_inv_cell[a] = h[a] > 0.f ? 1.f / h[a] : 0.f;
    view_.grid_dim[a] = dims[a];
  }
  // Coarse level first (1/4 resolution), so that fine cells walk a few steps from their parent's seed
  // instead of across the whole cloud from vertex 0.
  constexpr int kRatio = 4;
  int cd[3];
  for (int a = 0; a < 3; ++a) cd[a] = (dims[a] + kRatio - 1) / kRatio;
  DeviceBuffer<std::uint32_t> coarse(std::size_t(cd[0]) * cd[1] * cd[2]);
  DeviceGraphView g = view_;  // grid_seeds stays null: seed walks start where told
  gridSeedKernel<<<blocksFor(coarse.size()), kBlock>>>(g, cd[0], cd[1], cd[2], lo[0], lo[1], lo[2],
                                                       h[0] * kRatio, h[1] * kRatio, h[2] * kRatio, nullptr,
                                                       0, 0, 1, coarse.ptr());
  checkLaunch("DelaunayWalk: coarse start grid");
  grid_seeds_.create(std::size_t(dims[0]) * dims[1] * dims[2]);
  gridSeedKernel<<<blocksFor(grid_seeds_.size()), kBlock>>>(g, dims[0], dims[1], dims[2], lo[0], lo[1], lo[2],
                                                            h[0], h[1], h[2], coarse.ptr(), cd[0], cd[1],
                                                            kRatio, grid_seeds_.ptr());
  checkLaunch("DelaunayWalk: start grid");
  checkCuda(cudaDeviceSynchronize(), "DelaunayWalk: start grid");
  view_.grid_seeds = grid_seeds_.ptr();
}

int DelaunayWalk::defaultGroupSize(std::size_t /*num_vertices*/) {
  // Measured on the H100 with the float-first walk and 128-thread blocks (docs/gpu.md): 4 lanes were
  // fastest on both the 100k and the 437k dragon, in both layouts (8 lanes: +6 % / +30 %).
  return 4;
}

bool DelaunayWalk::defaultInlineNeighbourPositions(std::size_t num_directed_edges) {
  // Inline positions (16 bytes per edge) paid on the 100k dragon (26 MB: 20.9 vs 23.1 us at 4 lanes)
  // and not on the 437k one (115 MB, past the H100's 50 MB L2: 81.8 vs 80.5 us), docs/gpu.md.
  return num_directed_edges * sizeof(float4) <= (std::size_t(32) << 20);
}

void DelaunayWalk::setSafeBallTest(bool on) {
  safe_ball_ = on;
  view_.safe_ball = on && view_.num_vertices != 0;
}

void DelaunayWalk::setInlineNeighbourPositions(bool on) {
  auto_inline_ = false;
  applyInlineNeighbourPositions(on);
}

void DelaunayWalk::applyInlineNeighbourPositions(bool on) {
  if (!on) {
    edge_points_.release();
    view_.edge_points = nullptr;
    return;
  }
  const std::size_t m = neighbours_.size();
  edge_points_.create(m);
  if (m) {
    edgePointsKernel<<<blocksFor(m), kBlock>>>(points_.ptr(), neighbours_.ptr(), m, edge_points_.ptr());
    checkLaunch("DelaunayWalk: inline neighbour positions");
    checkCuda(cudaDeviceSynchronize(), "DelaunayWalk: inline neighbour positions");
  }
  view_.edge_points = m ? edge_points_.ptr() : nullptr;
}

void DelaunayWalk::toLocal(const dw::PointView& points, std::vector<float4>& out) const {
  out.resize(points.size);
  for (std::size_t i = 0; i < points.size; ++i) {
    const auto p = points[i];
    out[i] = make_float4(float(p[0] - origin_[0]), float(p[1] - origin_[1]), float(p[2] - origin_[2]), 0.f);
  }
}

void DelaunayWalk::setGroupSize(int lanes) {
  auto_group_size_ = lanes == 0;
  if (lanes == 0) lanes = defaultGroupSize(view_.num_vertices);
  if (lanes != 1 && lanes != 2 && lanes != 4 && lanes != 8 && lanes != 16 && lanes != 32)
    throw dw::Error("dw::gpu::DelaunayWalk::setGroupSize: lanes must be 0, 1, 2, 4, 8, 16 or 32, got " +
                    std::to_string(lanes));
  group_size_ = lanes;
}

void DelaunayWalk::nearest(const float4* q, std::size_t n, const std::uint32_t* hints,
                           std::uint32_t* vertices, float* dist2, std::uint32_t* steps,
                           cudaStream_t stream) const {
  if (n == 0) return;
  if (n >= kInvalid) throw dw::Error("dw::gpu::DelaunayWalk::nearest: too many queries for one batch");
  if (!q || !vertices || !dist2)
    throw dw::Error("dw::gpu::DelaunayWalk::nearest: null query or output pointer");
  switch (group_size_) {
    case 1: launchNearest<1>(view_, q, n, hints, vertices, dist2, steps, stream); break;
    case 2: launchNearest<2>(view_, q, n, hints, vertices, dist2, steps, stream); break;
    case 4: launchNearest<4>(view_, q, n, hints, vertices, dist2, steps, stream); break;
    case 16: launchNearest<16>(view_, q, n, hints, vertices, dist2, steps, stream); break;
    case 32: launchNearest<32>(view_, q, n, hints, vertices, dist2, steps, stream); break;
    default: launchNearest<8>(view_, q, n, hints, vertices, dist2, steps, stream); break;
  }
  checkLaunch("DelaunayWalk::nearest");
}

void DelaunayWalk::nearest(const DeviceBuffer<float4>& queries, const DeviceBuffer<std::uint32_t>* hints,
                           DeviceBuffer<std::uint32_t>& vertices, DeviceBuffer<float>& dist2,
                           DeviceBuffer<std::uint32_t>* steps, cudaStream_t stream) const {
  const std::size_t n = queries.size();
  if (hints && hints->size() != n)
    throw dw::Error("dw::gpu::DelaunayWalk::nearest: hints must have one entry per query");
  vertices.create(n);
  dist2.create(n);
  if (steps) steps->create(n);
  nearest(queries.ptr(), n, hints ? hints->ptr() : nullptr, vertices.ptr(), dist2.ptr(),
          steps ? steps->ptr() : nullptr, stream);
}

void DelaunayWalk::expand(const DeviceBuffer<float4>& queries, unsigned k, double radius2,
                          const DeviceBuffer<std::uint32_t>* hints, DeviceBuffer<std::uint32_t>& indices,
                          DeviceBuffer<float>& dist2, DeviceBuffer<std::uint32_t>& counts,
                          cudaStream_t stream) const {
  const std::size_t n = queries.size();
  if (hints && hints->size() != n)
    throw dw::Error("dw::gpu::DelaunayWalk: hints must have one entry per query");
  if (n >= kInvalid / std::max(1u, k))
    throw dw::Error("dw::gpu::DelaunayWalk: too many queries for one batch");
  indices.create(n * k);
  dist2.create(n * k);
  counts.create(n);
  if (n == 0) return;
  const std::uint32_t* h = hints ? hints->ptr() : nullptr;
  const unsigned blocks = unsigned((n + 127) / 128);
  const auto nn = std::uint32_t(n);
  if (k <= 8)
    expandKernel<8><<<blocks, 128, 0, stream>>>(view_, queries.ptr(), nn, h, k, radius2, indices.ptr(),
                                                dist2.ptr(), counts.ptr());
  else if (k <= 16)
    expandKernel<16><<<blocks, 128, 0, stream>>>(view_, queries.ptr(), nn, h, k, radius2, indices.ptr(),
                                                 dist2.ptr(), counts.ptr());
  else if (k <= 32)
    expandKernel<32><<<blocks, 128, 0, stream>>>(view_, queries.ptr(), nn, h, k, radius2, indices.ptr(),
                                                 dist2.ptr(), counts.ptr());
  else
    expandKernel<64><<<blocks, 128, 0, stream>>>(view_, queries.ptr(), nn, h, k, radius2, indices.ptr(),
                                                 dist2.ptr(), counts.ptr());
  checkLaunch("DelaunayWalk: kNN/radius expansion");
}

void DelaunayWalk::knn(const DeviceBuffer<float4>& queries, unsigned k,
                       const DeviceBuffer<std::uint32_t>* hints, DeviceBuffer<std::uint32_t>& indices,
                       DeviceBuffer<float>& dist2, DeviceBuffer<std::uint32_t>& counts,
                       cudaStream_t stream) const {
  if (k == 0 || k > kMaxK)
    throw dw::Error("dw::gpu::DelaunayWalk::knn: k must be in 1.." + std::to_string(kMaxK) + ", got " +
                    std::to_string(k));
  expand(queries, k, INFINITY, hints, indices, dist2, counts, stream);
}

void DelaunayWalk::radius(const DeviceBuffer<float4>& queries, float radius, unsigned max_nn,
                          const DeviceBuffer<std::uint32_t>* hints, DeviceBuffer<std::uint32_t>& indices,
                          DeviceBuffer<float>& dist2, DeviceBuffer<std::uint32_t>& counts,
                          cudaStream_t stream) const {
  if (!(radius >= 0.f) || !std::isfinite(radius))
    throw dw::Error("dw::gpu::DelaunayWalk::radius: radius must be finite and >= 0");
  if (max_nn == 0 || max_nn > kMaxK)
    throw dw::Error("dw::gpu::DelaunayWalk::radius: max_nn must be in 1.." + std::to_string(kMaxK) +
                    ", got " + std::to_string(max_nn));
  expand(queries, max_nn, double(radius) * double(radius), hints, indices, dist2, counts, stream);
}

void DelaunayWalk::bruteForceNearest(const float4* queries, std::size_t n, std::uint32_t* vertices,
                                     float* dist2, cudaStream_t stream) const {
  if (n == 0) return;
  if (n >= kInvalid)
    throw dw::Error("dw::gpu::DelaunayWalk::bruteForceNearest: too many queries for one batch");
  bruteForceKernel<<<blocksFor(n), kBlock, 0, stream>>>(view_.points, view_.num_vertices, queries,
                                                        std::uint32_t(n), vertices, dist2);
  checkLaunch("DelaunayWalk::bruteForceNearest");
}

void DelaunayWalk::verticesToInputs(std::uint32_t* vertices, std::size_t n, cudaStream_t stream) const {
  if (n == 0) return;
  mapKernel<<<blocksFor(n), kBlock, 0, stream>>>(vertex_to_input_dev_.ptr(), view_.num_vertices, vertices, n);
  checkLaunch("DelaunayWalk::verticesToInputs");
}

}  // namespace gpu
}  // namespace dw
