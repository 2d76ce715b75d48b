/// \file dw_walk_timing.cpp
/// \brief dw_walk_timing: the core walk's exact 1-NN on an ICP-like query sequence, PCL-free, so it runs
/// on the device machine and against other commits of this tree. The reference is a point file (or
/// uniform points); the queries are the reference moved by a small rigid motion that shrinks
/// iteration by iteration, in input order, as ICP issues them. Iteration 1 starts each walk by KD-ANN,
/// later iterations at the previous iteration's answer (PNN), and a last pass shows KD-ANN alone.
/// Prints the build time and ns/query per iteration (minimum over the repeats), and a checksum of the
/// answers that must not depend on the strategy (the walk is exact).
///   dw_walk_timing (-n POINTS | --file CLOUD) [--iterations I] [--repeats R] [--threads T]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

// The public headers moved into concept folders; this driver also builds against older trees.
#if __has_include("pcl_delaunay_walk/core/graph/graph_builder.h")
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#else
#include "pcl_delaunay_walk/core/graph_builder.h"
#include "pcl_delaunay_walk/core/neighbour_search.h"
#include "pcl_delaunay_walk/core/point_file.h"
#endif

namespace {

struct Options {
  std::size_t n = 0;
  std::string file;
  unsigned iterations = 5, repeats = 3, threads = 0;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw dw::Error("missing value after " + a);
      return argv[++i];
    };
    if (a == "-n") {
      std::string s = next();
      double m = 1;
      if (!s.empty() && (s.back() == 'k' || s.back() == 'M')) {
        m = s.back() == 'k' ? 1e3 : 1e6;
        s.pop_back();
      }
      o.n = static_cast<std::size_t>(std::stod(s) * m);
    } else if (a == "--file") {
      o.file = next();
    } else if (a == "--iterations") {
      o.iterations = static_cast<unsigned>(std::stoul(next()));
    } else if (a == "--repeats") {
      o.repeats = static_cast<unsigned>(std::stoul(next()));
    } else if (a == "--threads") {
      o.threads = static_cast<unsigned>(std::stoul(next()));
    } else {
      throw dw::Error("unknown option " + a);
    }
  }
  if (o.n == 0 && o.file.empty()) throw dw::Error("give -n POINTS or --file CLOUD");
  return o;
}

std::vector<double> referencePoints(const Options& o) {
  if (!o.file.empty()) return dw::readPointsXyz(o.file);
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> xyz(3 * o.n);
  for (double& c : xyz) c = u(rng);
  return xyz;
}

/// The reference rotated about its centre by `angle` (radians, about a fixed tilted axis) and shifted.
std::vector<float> movedQueries(const std::vector<double>& xyz, double angle, double shift) {
  const std::size_t n = xyz.size() / 3;
  double c[3] = {0, 0, 0};
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) c[k] += xyz[3 * i + k] / double(n);
  const double ax[3] = {0.48, 0.6, 0.64};  // unit axis
  const double cs = std::cos(angle), sn = std::sin(angle);
  std::vector<float> q(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const double p[3] = {xyz[3 * i] - c[0], xyz[3 * i + 1] - c[1], xyz[3 * i + 2] - c[2]};
    const double d = ax[0] * p[0] + ax[1] * p[1] + ax[2] * p[2];
    const double x[3] = {ax[1] * p[2] - ax[2] * p[1], ax[2] * p[0] - ax[0] * p[2],
                         ax[0] * p[1] - ax[1] * p[0]};
    for (int k = 0; k < 3; ++k)
      q[3 * i + k] = static_cast<float>(c[k] + p[k] * cs + x[k] * sn + ax[k] * d * (1 - cs) + shift);
  }
  return q;
}

/// One pass over the queries; returns ns/query and leaves each answer in `hints`.
double pass(const dw::NeighbourSearch& s, const dw::DelaunayGraph& g, const std::vector<float>& q,
            dw::StartStrategy strategy, std::vector<dw::index_t>& hints, std::uint64_t& checksum) {
  const std::size_t n = q.size() / 3;
  const auto t0 = std::chrono::steady_clock::now();
  std::uint64_t sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const dw::Vec3f ql = g.toLocal(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
    const dw::WalkResult r = s.nearest(ql, strategy, hints[i]);
    hints[i] = r.vertex;
    sum += r.vertex;
  }
  const auto t1 = std::chrono::steady_clock::now();
  checksum = sum;
  return std::chrono::duration<double, std::nano>(t1 - t0).count() / double(n);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options o = parse(argc, argv);
    const std::vector<double> xyz = referencePoints(o);
    const std::size_t n = xyz.size() / 3;
    dw::BuildOptions bo;
    bo.num_threads = o.threads;
    const auto b0 = std::chrono::steady_clock::now();
    auto g = std::make_shared<dw::DelaunayGraph>(
        dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), n), bo));
    const auto b1 = std::chrono::steady_clock::now();
    const dw::NeighbourSearch s(g);
    std::printf("points %zu  vertices %zu  build_s %.3f\n", n, g->numVertices(),
                std::chrono::duration<double>(b1 - b0).count());
    double extent = 0;
    for (std::size_t i = 0; i < 3 * n; ++i) extent = std::max(extent, std::abs(xyz[i] - xyz[i % 3]));
    std::vector<double> best(o.iterations + 1, 1e300);
    std::uint64_t first_sum = 0, sum = 0;
    bool same = true;
    for (unsigned r = 0; r < o.repeats; ++r) {
      std::vector<dw::index_t> hints(n, dw::kInvalidIndex);
      for (unsigned it = 0; it < o.iterations; ++it) {
        const double shrink = std::pow(0.5, it);
        const auto q = movedQueries(xyz, 0.02 * shrink, 0.002 * extent * shrink);
        const auto strategy = it == 0 ? dw::StartStrategy::KdAnn : dw::StartStrategy::Pnn;
        best[it] = std::min(best[it], pass(s, *g, q, strategy, hints, sum));
      }
      std::vector<dw::index_t> none(n, dw::kInvalidIndex);
      const auto q = movedQueries(xyz, 0.02 * std::pow(0.5, o.iterations - 1), 0.0);
      best[o.iterations] = std::min(best[o.iterations], pass(s, *g, q, dw::StartStrategy::KdAnn, none, sum));
      std::vector<dw::index_t> pnn = hints;
      std::uint64_t pnn_sum = 0;
      pass(s, *g, q, dw::StartStrategy::Pnn, pnn, pnn_sum);
      if (r == 0) first_sum = sum;
      same = same && sum == first_sum && pnn_sum == sum;
    }
    for (unsigned it = 0; it < o.iterations; ++it)
      std::printf("iteration %u (%s)  %.1f ns/query\n", it + 1, it == 0 ? "kd-ann" : "pnn", best[it]);
    std::printf("kd-ann alone        %.1f ns/query\n", best[o.iterations]);
    std::printf("checksum %llu  %s\n", static_cast<unsigned long long>(first_sum),
                same ? "same answers for every strategy and repeat" : "ANSWERS DIFFER");
    return same ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_walk_timing: error: %s\n", e.what());
    return 1;
  }
}
