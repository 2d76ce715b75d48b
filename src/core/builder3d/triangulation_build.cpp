// Triangulation3D's build: the input's checks, the first tetrahedron, then the vertices one by one
// up to the first batch and batch by batch (BRIO rounds) through the parallel insertion.
#include <algorithm>
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "core/builder3d/triangulation_3d.h"
#include "core/geometry/affine_span.h"
#include "core/util/page_memory.h"
#include "pcl_delaunay_walk/core/geometry/predicates_3d.h"

namespace dw {
namespace builder3d {

void Triangulation3D::setPoints(const Vec3f* points, std::size_t n) {
  if (n > kMaxVertices)
    throw Error("dw::Triangulation3D: " + std::to_string(n) + " points exceed the kernel's limit of " +
                std::to_string(kMaxVertices));
  if (n > 0 && points == nullptr) throw Error("dw::Triangulation3D: null point array");
  points_ = points;
  num_points_ = n;
  if (vertex_tet_.size() < n) vertex_tet_.resize(n, kNoVertexTet);
}

void Triangulation3D::initialTetrahedron(index_t a, index_t b, index_t c, index_t d) {
  double pa[3], pb[3], pc[3], pd[3];
  point(a, pa);
  point(b, pb);
  point(c, pc);
  point(d, pd);
  if (predicates::orient3d(pa, pb, pc, pd) < 0.0) std::swap(a, b);
  const index_t base[4] = {a, b, c, d};
  for (int k = 0; k < 5; ++k) newTet();
  std::copy(base, base + 4, &mesh_.tet_v[0]);
  for (unsigned i = 0; i < 4; ++i) {
    // Replace v_i by infinity; swapping two other vertices makes the far side of the facet positive.
    index_t* v = &mesh_.tet_v[4 * std::size_t(i + 1)];
    std::copy(base, base + 4, v);
    v[i] = kInfinite;
    std::swap(v[(i + 1) % 4], v[(i + 2) % 4]);
  }
  // Five tetrahedra: match faces by their vertex sets.
  auto faceSet = [&](index_t t, unsigned f) {
    std::array<index_t, 3> s{};
    unsigned k = 0;
    for (unsigned j = 0; j < 4; ++j)
      if (j != f) s[k++] = mesh_.tet_v[4 * std::size_t(t) + j];
    std::sort(s.begin(), s.end());
    return s;
  };
  for (index_t t = 0; t < 5; ++t)
    for (unsigned f = 0; f < 4; ++f)
      for (index_t u = 0; u < 5; ++u)
        for (unsigned g = 0; g < 4; ++g)
          if (u != t && faceSet(t, f) == faceSet(u, g)) mesh_.tet_n[4 * std::size_t(t) + f] = 4 * u + g;
  last_tet_ = 0;
}

void Triangulation3D::build(const index_t* order, std::size_t n,
                            const std::function<void(double)>& progress) {
  build(order, n, progress, {}, 1);
}

void Triangulation3D::build(const index_t* order, std::size_t n, const std::function<void(double)>& progress,
                            const std::vector<std::size_t>& batch_begin, unsigned num_threads) {
  buildBatches(order, n, progress, batch_begin, num_threads, nullptr);
}

void Triangulation3D::build(std::vector<index_t>&& order, const std::function<void(double)>& progress,
                            const std::vector<std::size_t>& batch_begin, unsigned num_threads) {
  buildBatches(order.data(), order.size(), progress, batch_begin, num_threads, &order);
}

std::pair<std::size_t, std::size_t> Triangulation3D::startBuild(const index_t* order, std::size_t n) {
  if (points_ == nullptr && n > 0) throw Error("dw::Triangulation3D::build: setPoints() was not called");
  mesh_.clear();
  num_inserted_ = 0;
  stats_ = Stats{};
  seq_ = Worker{};
  if (n < 4) throw Error("dw::Triangulation3D::build: a 3D triangulation needs at least 4 points");
  for (std::size_t i = 0; i < n; ++i)
    if (order[i] >= num_points_) throw Error("dw::Triangulation3D::build: vertex id out of range");

  // The first tetrahedron: order[0], order[1] (distinct by contract), then the first point off
  // their line, then the first point off their plane.
  if (points_[order[0]].x == points_[order[1]].x && points_[order[0]].y == points_[order[1]].y &&
      points_[order[0]].z == points_[order[1]].z)
    throw Error("dw::Triangulation3D::build: duplicate points (the input must be distinct)");
  std::size_t first[4];
  const int dim = affineSpan(points_, order, n, first);
  if (dim < 2) throw Error("dw::Triangulation3D::build: all points are collinear (not a 3D set)");
  if (dim < 3) throw Error("dw::Triangulation3D::build: all points are coplanar (not a 3D set)");
  const std::size_t kc = first[2], kd = first[3];  // first[1] is 1: order[1] differs from order[0]

  // ~6.75 per vertex on volumetric input, more on surfaces and with recycled slots; reserving 8 avoids
  // a late reallocation, which would hold old and new arrays at once (measured 324 B/point at 4M
  // points against 216 at 1M; the dragon 336 B/point with 7, 276 with 8). Pages never touched cost
  // address space only.
  const std::size_t expected_tets = n * 8 + 64;
  mesh_.reserveSlots(expected_tets);
  initialTetrahedron(order[0], order[1], order[kc], order[kd]);
  num_inserted_ = 4;
  return {kc, kd};
}

void Triangulation3D::buildBatches(const index_t* order, std::size_t n,
                                   const std::function<void(double)>& progress,
                                   const std::vector<std::size_t>& batch_begin, unsigned num_threads,
                                   std::vector<index_t>* owned) {
  const auto [kc, kd] = startBuild(order, n);

  // Batches (BRIO rounds): each is inserted by insertParallel, which runs threads when it is big
  // enough; positions before the first batch go in one by one.
  std::vector<std::size_t> begin;
  for (std::size_t b : batch_begin)
    if (b > 2 && b < n && (begin.empty() || b > begin.back())) begin.push_back(b);
  begin.push_back(n);
  const std::size_t report_every = std::max<std::size_t>(1, n / 100);
  for (std::size_t i = 2; i < begin.front(); ++i) {
    if (i == kc || i == kd) continue;
    insert(order[i]);
    if (progress && i % report_every == 0) progress(static_cast<double>(i) / n);
  }
  // Each batch is copied (without the first tetrahedron's vertices) and handed over as the batch's
  // pending list. The last one is half the points: an order we own is freed before it goes in.
  for (std::size_t r = 0; r + 1 < begin.size(); ++r) {
    std::vector<index_t> batch;
    batch.reserve(begin[r + 1] - begin[r]);
    for (std::size_t i = begin[r]; i < begin[r + 1]; ++i)
      if (i != kc && i != kd) batch.push_back(order[i]);
    if (owned != nullptr && r + 2 == begin.size()) {
      detail::freeScratch(*owned);  // its pages leave the process (a plain free kept them in the heap)
      order = nullptr;
    }
    insertBatch(std::move(batch), num_threads);
    if (progress) progress(static_cast<double>(begin[r + 1]) / n);
  }
  if (progress) progress(1.0);
}

}  // namespace builder3d
}  // namespace dw
