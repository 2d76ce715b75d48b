// The 3D builder's peak memory when graphs are built one after another in one process (the
// scan-to-scan case builds one per frame): each build must stay within 250 bytes per
// point, not only the first. Unless the triangulation gives its freed arrays' pages back, glibc keeps
// them resident once an earlier build has raised its mmap threshold, and the edge extraction's
// buffers land on fresh pages beside them (the second 100k-point build on 2 threads: 259 B/pt).
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "core/util/process_memory.h"
#include "core/util/space_filling_curve.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"

namespace {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kOwnAllocator = false;  // the sanitizers replace malloc and pad every block
#elif defined(__linux__) && defined(__GLIBC__)
constexpr bool kOwnAllocator = true;
#else
constexpr bool kOwnAllocator = false;  // no VmHWM to read
#endif

TEST(BuilderMemory, RepeatedBuildsStayWithinTheirPeak) {
  if (!kOwnAllocator) GTEST_SKIP() << "needs glibc's malloc and Linux's VmHWM (not under a sanitizer)";
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<dw::Vec3f> raw(100000);
  for (auto& p : raw) p = {u(rng), u(rng), u(rng)};
  const std::vector<dw::Vec3f> pts = dw::mortonSortedDistinct(raw);
  dw::BuildOptions options;
  options.num_threads = 2;
  const std::size_t edges = dw::incrementalDelaunayEdges(pts, options).size();
  for (int build = 1; build <= 2; ++build) {
    dw::resetPeakResident();
    const long base_kb = dw::processStatusKb("VmHWM:");
    ASSERT_GT(base_kb, 0);
    const dw::EdgeList e = dw::incrementalDelaunayEdges(pts, options);
    const double bytes_per_point = 1024.0 * double(dw::processStatusKb("VmHWM:") - base_kb) / pts.size();
    EXPECT_EQ(e.size(), edges);
    EXPECT_LE(bytes_per_point, 250.0) << "build " << build + 1;
    EXPECT_GT(bytes_per_point, 100.0) << "the peak must at least hold the tetrahedra";
  }
}

}  // namespace
