// libFuzzer target: buildDelaunayGraph + NeighbourSearch on arbitrary point sets, every answer checked
// against brute force inside the fuzzer (nearest under every start strategy, kNN, radius).
//
// The first byte picks how the remaining bytes become points, so the fuzzer spends its time on the
// inputs that break Delaunay code: small integer grids (duplicates, coplanar, collinear, cocircular
// and cospherical sets), georeferenced quantised coordinates, and raw float bit patterns (NaN, Inf,
// subnormals, huge values).
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "fuzz_common.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"

namespace {

enum Mode { kGrid = 0, kGeoreferenced = 1, kRawFloat = 2, kFlat = 3 };

double coordinate(FuzzedDataProvider& in, int mode, int axis) {
  switch (mode) {
    case kGrid: return in.ConsumeIntegralInRange<int>(-6, 6);
    case kGeoreferenced: {
      const double offset[3] = {512345.0, 6001234.0, 120.0};  // UTM-like, LAS centimetre quantum
      return offset[axis] + 0.01 * in.ConsumeIntegral<std::int16_t>();
    }
    case kRawFloat: return in.ConsumeFloatingPoint<float>();
    default:  // kFlat: one axis pinned, so coplanar and collinear sets are common
      return axis == 2 ? 0.0 : 0.25 * in.ConsumeIntegralInRange<int>(-40, 40);
  }
}

/// The failing case as numbers, so a report (and a regression test) can quote it.
void dump(int mode, bool qhull, const std::vector<double>& xyz, const double q[3]) {
  std::fprintf(stderr, "mode %d, builder %s, %zu points (x y z):\n", mode, qhull ? "qhull" : "auto",
               xyz.size() / 3);
  for (std::size_t i = 0; i + 2 < xyz.size() && i < 3 * 300; i += 3)
    std::fprintf(stderr, "  %.17g, %.17g, %.17g,\n", xyz[i], xyz[i + 1], xyz[i + 2]);
  std::fprintf(stderr, "query: %.17g, %.17g, %.17g\n", q[0], q[1], q[2]);
}

bool finite3(const double* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const int mode = in.ConsumeIntegralInRange<int>(0, 3);
  const bool qhull = in.ConsumeBool() && dw::haveQhullBuilder();
  const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(0, 200);
  std::vector<double> xyz;
  for (std::size_t i = 0; i < n && in.remaining_bytes() > 0; ++i)
    for (int a = 0; a < 3; ++a) xyz.push_back(coordinate(in, mode, a));
  xyz.resize(xyz.size() / 3 * 3);
  const std::size_t np = xyz.size() / 3;

  // Float-safe clouds must build: every finite extent whose squared distances fit in float.
  double lo = INFINITY, hi = -INFINITY;
  std::size_t finite = 0;
  for (std::size_t i = 0; i < np; ++i)
    if (finite3(&xyz[3 * i])) {
      ++finite;
      for (int a = 0; a < 3; ++a) lo = std::min(lo, xyz[3 * i + a]), hi = std::max(hi, xyz[3 * i + a]);
    }
  const double extent = finite ? hi - lo : 0.0;
  const bool float_safe = extent < 1e17;

  dw::BuildOptions options;
  options.builder = qhull ? dw::BuilderType::Qhull : dw::BuilderType::Auto;
  options.num_threads = 1;
  std::shared_ptr<dw::DelaunayGraph> g;
  try {
    g = std::make_shared<dw::DelaunayGraph>(
        dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), np), options));
  } catch (const dw::Error& e) {
    if (float_safe) {
      std::fprintf(stderr, "build refused a float-safe cloud of %zu points (extent %g): %s\n", np, extent,
                   e.what());
      std::abort();
    }
    return 0;
  }
  // Every graph the builder returns must pass its own validation, also near the float range (B7).
  g->validate();
  DW_FUZZ_CHECK(g->originals.size() == finite, "finite points were dropped or invented");
  if (!float_safe) return 0;  // squared distances overflow float: every comparison ties

  const dw::NeighbourSearch search(g);
  float scale2 = 0.f;
  for (const dw::Vec3f& p : g->points) scale2 = std::max(scale2, 4.f * dw::dot(p, p));
  auto tol = [&](float d2) { return 1e-5f * d2 + 1e-6f * scale2; };
  std::vector<dw::index_t> idx;
  std::vector<float> d2;
  std::vector<float> all;
  for (int qn = 0; qn < 12 && (qn < 2 || in.remaining_bytes() > 0); ++qn) {
    double qd[3];
    for (int a = 0; a < 3; ++a)
      qd[a] = mode == kRawFloat ? in.ConsumeFloatingPointInRange<float>(-1e6f, 1e6f)
                                : coordinate(in, mode, a) + 0.5 * in.ConsumeProbability<double>();
    const dw::Vec3f q = g->toLocal(qd[0], qd[1], qd[2]);
    all.clear();
    for (std::size_t i = 0; i < np; ++i)
      if (finite3(&xyz[3 * i]))
        all.push_back(dw::squaredDistance(q, g->toLocal(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2])));
    std::sort(all.begin(), all.end());
    if (all.empty()) {
      DW_FUZZ_CHECK(search.nearest(q).vertex == dw::kInvalidIndex, "empty graph gave a nearest vertex");
      continue;
    }
    for (dw::StartStrategy s : {dw::StartStrategy::Zero, dw::StartStrategy::KdAnn, dw::StartStrategy::Pnn,
                                dw::StartStrategy::PnnOptimized}) {
      const dw::WalkResult r = search.nearest(q, s, dw::index_t(qn * 31));
      DW_FUZZ_CHECK(r.vertex < g->numVertices(), "nearest out of range");
      if (std::fabs(r.dist2 - all[0]) > tol(all[0])) {
        std::fprintf(stderr, "nearest (%s) dist2 %.9g, brute force %.9g\n", dw::toString(s), r.dist2, all[0]);
        dump(mode, qhull, xyz, qd);
        std::abort();
      }
    }
    const dw::WalkResult nn = search.nearest(q);
    const std::size_t k = 1 + std::size_t(qn) * 5 % (all.size() + 2);
    search.knn(q, k, nn, idx, d2);
    DW_FUZZ_CHECK(idx.size() == std::min(k, all.size()), "knn count");
    for (std::size_t r = 0; r < idx.size(); ++r) {
      DW_FUZZ_CHECK(idx[r] < np && finite3(&xyz[3 * idx[r]]), "knn returned a bad index");
      const float own =
          dw::squaredDistance(q, g->toLocal(xyz[3 * idx[r]], xyz[3 * idx[r] + 1], xyz[3 * idx[r] + 2]));
      if (std::fabs(d2[r] - all[r]) > tol(all[r]) || std::fabs(own - d2[r]) > tol(own)) {
        std::fprintf(stderr, "knn(%zu) rank %zu: dist2 %.9g (own %.9g), brute force %.9g\n", k, r, d2[r], own,
                     all[r]);
        dump(mode, qhull, xyz, qd);
        std::abort();
      }
    }
    const float r2 = all[std::min<std::size_t>(all.size() - 1, std::size_t(qn) % 7)];
    search.radius(q, r2, nn, idx, d2);
    const std::size_t must = std::lower_bound(all.begin(), all.end(), r2 - tol(r2)) - all.begin();
    const std::size_t may = std::upper_bound(all.begin(), all.end(), r2 + tol(r2)) - all.begin();
    if (idx.size() < must || idx.size() > may) {
      std::fprintf(stderr, "radius2 %.9g: %zu results, brute force %zu..%zu\n", r2, idx.size(), must, may);
      dump(mode, qhull, xyz, qd);
      std::abort();
    }
  }
  return 0;
}
