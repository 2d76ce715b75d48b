// libFuzzer target: dw::tin::triangulate on arbitrary 2D point sets, checked inside the fuzzer by the
// independent certificate (valid triangulation of the hull, every interior edge locally Delaunay) and
// by strip invariance: the symbolic tie-break makes the triangle set independent of the strip count.
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "fuzz_common.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace {

std::vector<std::array<dw::index_t, 3>> canonical(const std::vector<dw::index_t>& t) {
  std::vector<std::array<dw::index_t, 3>> out;
  for (std::size_t i = 0; i + 2 < t.size(); i += 3) {
    std::array<dw::index_t, 3> a{t[i], t[i + 1], t[i + 2]};
    std::rotate(a.begin(), std::min_element(a.begin(), a.end()), a.end());  // keeps orientation
    out.push_back(a);
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// The failing input as numbers, so a report can quote it.
void dumpPoints(int mode, const std::vector<double>& x, const std::vector<double>& y) {
  std::fprintf(stderr, "mode %d, %zu points:\n", mode, x.size());
  for (std::size_t i = 0; i < x.size() && i < 64; ++i)
    std::fprintf(stderr, "  %zu: %.17g %.17g\n", i, x[i], y[i]);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  // Mode 0: small integer grid (cocircular ties, duplicates, collinear runs); 1: LAS-like quantised
  // georeferenced coordinates; 2: raw doubles (NaN, Inf, subnormals, huge); 3: doubles within 1e50.
  const int mode = in.ConsumeIntegralInRange<int>(0, 3);
  const unsigned strips = in.ConsumeIntegralInRange<unsigned>(2, 6);
  const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(0, 400);
  std::vector<double> x, y;
  for (std::size_t i = 0; i < n && in.remaining_bytes() > 0; ++i) {
    double p[2];
    for (double& c : p) {
      if (mode == 0)
        c = in.ConsumeIntegralInRange<int>(-10, 10);
      else if (mode == 1)
        c = 0.01 * in.ConsumeIntegralInRange<int>(0, 30000);
      else if (mode == 2)
        c = in.ConsumeFloatingPoint<double>();  // any double: NaN, Inf, subnormal, 1e308
      else
        c = in.ConsumeFloatingPointInRange<double>(-1e50, 1e50);  // wide but mostly representable
    }
    x.push_back(p[0]);
    y.push_back(p[1]);
  }
  dw::tin::TinOptions seq;
  seq.num_threads = 1;
  seq.num_strips = 1;
  dw::tin::TinResult a;
  try {
    a = dw::tin::triangulate(x.data(), y.data(), x.size(), seq);
  } catch (const dw::Error& e) {
    // Only raw/wide doubles may be refused (magnitudes the exact predicates cannot take); the others
    // are ordinary LiDAR-like input and must triangulate.
    if (mode < 2) {
      std::fprintf(stderr, "triangulate refused %zu points: %s\n", x.size(), e.what());
      dumpPoints(mode, x, y);
      std::abort();
    }
    return 0;
  }
  for (dw::index_t t : a.triangles) DW_FUZZ_CHECK(t < x.size(), "triangle index out of range");
  const dw::tin::Certificate cert =
      dw::tin::certifyDelaunay(x.data(), y.data(), x.size(), a.triangles, a.degenerate ? 0 : a.num_vertices);
  if (!a.degenerate && !cert.ok) {
    std::fprintf(stderr, "sequential TIN of %zu points is not Delaunay: %s\n", x.size(),
                 cert.message.c_str());
    dumpPoints(mode, x, y);
    std::abort();
  }
  dw::tin::TinOptions par;
  par.num_threads = 2;
  par.num_strips = strips;
  const dw::tin::TinResult b = dw::tin::triangulate(x.data(), y.data(), x.size(), par);
  if (canonical(a.triangles) != canonical(b.triangles)) {
    std::fprintf(stderr, "%u strips give a different TIN than 1 strip (%zu vs %zu triangles)\n", strips,
                 b.numTriangles(), a.numTriangles());
    dumpPoints(mode, x, y);
    std::abort();
  }
  return 0;
}
