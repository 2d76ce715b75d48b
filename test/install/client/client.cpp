// A downstream project: builds a graph and answers one query through the installed package.
#include <pcl_delaunay_walk/core/graph/graph_builder.h>
#include <pcl_delaunay_walk/core/search/neighbour_search.h>

#include <cstdio>
#include <memory>
#include <vector>

#ifdef CLIENT_WITH_PCL
std::size_t quickStart();
#endif

int main() {
#ifdef CLIENT_WITH_PCL
  const std::size_t q = quickStart();
  std::printf("client: README quick start ran (%zu)\n", q);
  if (q != 9) return 1;
#endif
  std::vector<float> xyz;
  for (int i = 0; i < 1000; ++i)
    xyz.insert(xyz.end(), {float(i % 10), float(i / 10 % 10), float(i / 100) + 0.01f * (i % 7)});
  auto g =
      std::make_shared<dw::DelaunayGraph>(dw::buildDelaunayGraph(dw::PointView::fromFloat(xyz.data(), 1000)));
  dw::NeighbourSearch s(g);
  const auto r = s.nearest(g->toLocal(3.1, 4.2, 5.0));
  std::printf("client: %zu vertices, nearest vertex %u at d2 %.4f\n", g->numVertices(), r.vertex, r.dist2);
  return r.vertex == dw::kInvalidIndex ? 1 : 0;
}
