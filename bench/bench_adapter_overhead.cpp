// Google Benchmark: what the PCL adapter costs over the core, for the same queries on the same graph.
//
//   <query>/core      dw::NeighbourSearch in the graph's local frame (start by KD-ANN, walk, expand)
//   NN/core_index     NN/core with the answer vertex mapped to the input index a caller refers to
//                     (DelaunayGraph::representative), as the core's knn() and radius() answer
//   <query>/caller    dw::CallerMetricSearch: the same, certified in the caller's float metric
//   <query>/adapter   pcl::search::DelaunayWalk<PointXYZ> (Indices / vector<float> out, PCL's API)
//   <query>/kdtree    pcl::search::KdTree<PointXYZ>, the class the adapter replaces (reference)
//
// <query>: NN (k = 1), kNN8, kNN16, radius (a radius holding ~16 points on average). The cloud is
// data/bun000.ply (40,256 points, bundled); the queries are 20,000 of its points moved by ~0.2 of
// the point spacing, as NormalEstimation or ICP near convergence would ask. Compare items_per_second:
// adapter / core is the adapter's overhead (for NN, adapter / core_index over the same answer: input
// indices), caller / core the part that certification takes.
#include <benchmark/benchmark.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/search/caller_metric_search.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"

namespace {

using P = pcl::PointXYZ;

struct Setup {
  pcl::PointCloud<P>::Ptr cloud{new pcl::PointCloud<P>};
  std::vector<P> queries;
  pcl::search::DelaunayWalk<P> walk;
  pcl::search::KdTree<P> kdtree;
  double radius = 0.0;

  Setup() {
    // DW_DATA_DIR: where the bundled data lies on a machine the binary was carried to.
    const char* dir = std::getenv("DW_DATA_DIR");
    const std::vector<double> xyz =
        dw::readPointsXyz(std::string(dir ? dir : DW_TEST_DATA_DIR) + "/bun000.ply");
    for (std::size_t i = 0; i < xyz.size() / 3; ++i)
      cloud->push_back(P(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2])));
    walk.setInputCloud(cloud);
    kdtree.setInputCloud(cloud);
    // Spacing from the 1-NN distances of a sample; the radius that holds ~16 neighbours on a surface.
    std::mt19937 rng(7);
    std::uniform_int_distribution<std::size_t> pick(0, cloud->size() - 1);
    pcl::Indices idx;
    std::vector<float> d2;
    double spacing = 0.0;
    for (int i = 0; i < 200; ++i) {
      kdtree.nearestKSearch(static_cast<pcl::index_t>(pick(rng)), 2, idx, d2);
      spacing += std::sqrt(d2[1]) / 200.0;
    }
    radius = 2.2 * spacing;
    std::normal_distribution<float> jitter(0.f, 0.2f * static_cast<float>(spacing));
    for (int i = 0; i < 20000; ++i) {
      const P& p = (*cloud)[pick(rng)];
      queries.emplace_back(p.x + jitter(rng), p.y + jitter(rng), p.z + jitter(rng));
    }
  }
};

Setup& setup() {
  static Setup s;
  return s;
}

enum class Query { NN, kNN8, kNN16, Radius };

int kOf(Query q) {
  return q == Query::NN ? 1 : q == Query::kNN8 ? 8 : 16;
}

/// The core's answers; kIndices maps the NN answer vertex to its input index (knn() and radius()
/// answer input indices already).
template <bool kIndices>
void core(benchmark::State& state, Query kind) {
  Setup& s = setup();
  const dw::NeighbourSearch& ns = s.walk.getCallerMetricSearch()->neighbourSearch();
  const dw::DelaunayGraph& g = ns.graph();
  std::vector<dw::index_t> idx;
  std::vector<float> d2;
  const float r2 = static_cast<float>(s.radius * s.radius);
  std::size_t found = 0;
  for (auto _ : state) {
    for (const P& q : s.queries) {
      const dw::Vec3f ql = g.toLocal(q.x, q.y, q.z);
      const dw::WalkResult nn = ns.nearest(ql, dw::StartStrategy::KdAnn);
      if (kind == Query::NN) {
        found += kIndices ? g.representative(nn.vertex) : nn.vertex;
        continue;
      }
      found += kind == Query::Radius ? ns.radius(ql, r2, nn, idx, d2, 0)
                                     : ns.knn(ql, static_cast<std::size_t>(kOf(kind)), nn, idx, d2);
    }
  }
  benchmark::DoNotOptimize(found);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * s.queries.size()));
}

void caller(benchmark::State& state, Query kind) {
  Setup& s = setup();
  const dw::CallerMetricSearch& cm = *s.walk.getCallerMetricSearch();
  std::vector<dw::WalkNeighbour> out;
  dw::WalkNeighbour nb;
  std::size_t found = 0;
  for (auto _ : state) {
    for (const P& q : s.queries) {
      const float f[3] = {q.x, q.y, q.z};
      if (kind == Query::NN)
        found += cm.nearest(f, dw::StartStrategy::KdAnn, dw::kInvalidIndex, nb) ? 1 : 0;
      else if (kind == Query::Radius)
        found += cm.radius(f, s.radius, 0, dw::StartStrategy::KdAnn, dw::kInvalidIndex, out);
      else
        found +=
            cm.knn(f, static_cast<std::size_t>(kOf(kind)), dw::StartStrategy::KdAnn, dw::kInvalidIndex, out);
    }
  }
  benchmark::DoNotOptimize(found);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * s.queries.size()));
}

void pclSearch(benchmark::State& state, Query kind, const pcl::search::Search<P>& search) {
  Setup& s = setup();
  pcl::Indices idx;
  std::vector<float> d2;
  std::size_t found = 0;
  for (auto _ : state) {
    for (const P& q : s.queries) {
      if (kind == Query::Radius)
        found += static_cast<std::size_t>(search.radiusSearch(q, s.radius, idx, d2, 0));
      else
        found += static_cast<std::size_t>(search.nearestKSearch(q, kOf(kind), idx, d2));
    }
  }
  benchmark::DoNotOptimize(found);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * s.queries.size()));
}

void registerAll() {
  const std::pair<const char*, Query> kinds[] = {
      {"NN", Query::NN}, {"kNN8", Query::kNN8}, {"kNN16", Query::kNN16}, {"radius", Query::Radius}};
  for (const auto& [name, kind] : kinds) {
    const Query k = kind;
    const std::string n = name;
    benchmark::RegisterBenchmark((n + "/core").c_str(), [k](benchmark::State& st) { core<false>(st, k); });
    if (k == Query::NN)
      benchmark::RegisterBenchmark((n + "/core_index").c_str(),
                                   [k](benchmark::State& st) { core<true>(st, k); });
    benchmark::RegisterBenchmark((n + "/caller").c_str(), [k](benchmark::State& st) { caller(st, k); });
    benchmark::RegisterBenchmark((n + "/adapter").c_str(),
                                 [k](benchmark::State& st) { pclSearch(st, k, setup().walk); });
    benchmark::RegisterBenchmark((n + "/kdtree").c_str(),
                                 [k](benchmark::State& st) { pclSearch(st, k, setup().kdtree); });
  }
}

}  // namespace

int main(int argc, char** argv) {
  registerAll();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
