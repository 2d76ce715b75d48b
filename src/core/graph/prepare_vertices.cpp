// The input preparation of buildDelaunayGraph, stage by stage (prepare_vertices.h).
#include "core/graph/prepare_vertices.h"

#include <cmath>
#include <string>
#include <vector>

#include "core/util/page_memory.h"
#include "core/util/parallel_sort.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace detail {
namespace {

constexpr std::size_t kMinBlock = std::size_t(1) << 16;

/// The finite input points (ascending input index) and their bounding box.
struct FinitePoints {
  std::vector<index_t> index;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
};

FinitePoints scanFinite(const PointView& view, unsigned threads) {
  const std::size_t n = view.size;
  std::vector<FinitePoints> blocks(workerCount(n, threads, kMinBlock));
  parallelFor(n, static_cast<unsigned>(blocks.size()), [&](std::size_t b, std::size_t e, unsigned w) {
    FinitePoints& block = blocks[w];
    block.index.reserve(e - b);
    for (std::size_t i = b; i < e; ++i) {
      const auto p = view[i];
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
      block.index.push_back(static_cast<index_t>(i));
      for (int a = 0; a < 3; ++a)
        block.lo[a] = std::min(block.lo[a], p[a]), block.hi[a] = std::max(block.hi[a], p[a]);
    }
  });
  FinitePoints all;
  std::size_t count = 0;
  for (const FinitePoints& block : blocks) count += block.index.size();
  all.index.reserve(count);
  for (FinitePoints& block : blocks) {
    all.index.insert(all.index.end(), block.index.begin(), block.index.end());
    freeScratch(block.index);
    for (int a = 0; a < 3; ++a)
      all.lo[a] = std::min(all.lo[a], block.lo[a]), all.hi[a] = std::max(all.hi[a], block.hi[a]);
  }
  return all;
}

/// Local float coordinates and Morton keys of the finite points, in input order.
std::vector<MortonItem> mortonItems(const PointView& view, const std::vector<index_t>& finite,
                                    const MortonQuantiser& quantiser, const DelaunayGraph& g,
                                    unsigned threads) {
  std::vector<MortonItem> items(finite.size());
  parallelFor(finite.size(), workerCount(finite.size(), threads, kMinBlock),
              [&](std::size_t b, std::size_t e, unsigned) {
                for (std::size_t k = b; k < e; ++k) {
                  const auto p = view[finite[k]];
                  MortonItem& it = items[k];
                  it.p = g.toLocal(p[0], p[1], p[2]);
                  it.input = finite[k];
                  it.key = quantiser.key(it.p);
                }
              });
  return items;
}

/// One sort both orders the items along the curve and makes exact duplicates adjacent. The keys are
/// 63 bits (21 per axis); their top 16 bucket the items first.
void sortItems(std::vector<MortonItem>& items, unsigned threads) {
  bucketThenSort(
      items, 1u << 16, [](const MortonItem& it) { return static_cast<unsigned>(it.key >> 47); },
      [](const MortonItem& a, const MortonItem& b) { return mortonItemLess(a, b); }, threads);
}

/// Each run of equal positions is one vertex, which keeps the run's input indices (ascending) as its
/// originals. Per block: count the vertices that start there; then, from each block's first vertex
/// number, write the vertices, originals and maps.
void collapseDuplicates(const std::vector<MortonItem>& items, unsigned threads, DelaunayGraph& g) {
  const std::size_t m = items.size();
  auto startsVertex = [&](std::size_t k) { return k == 0 || !samePosition(items[k].p, items[k - 1].p); };
  const unsigned workers = workerCount(m, threads, kMinBlock);
  std::vector<std::size_t> first_vertex(workers + 1, 0);
  parallelFor(m, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    std::size_t starts = 0;
    for (std::size_t k = b; k < e; ++k) starts += startsVertex(k);
    first_vertex[w + 1] = starts;
  });
  for (unsigned w = 0; w < workers; ++w) first_vertex[w + 1] += first_vertex[w];
  const std::size_t num_vertices = first_vertex[workers];
  g.points.resize(num_vertices);
  g.originals.resize(m);
  g.originals_offsets.resize(num_vertices + 1);
  g.originals_offsets[num_vertices] = static_cast<index_t>(m);
  parallelFor(m, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    std::size_t v = first_vertex[w];  // the number of the next vertex to start
    for (std::size_t k = b; k < e; ++k) {
      if (startsVertex(k)) {
        g.points[v] = items[k].p;
        g.originals_offsets[v] = static_cast<index_t>(k);
        ++v;
      }
      g.originals[k] = items[k].input;
      g.input_to_vertex[items[k].input] = static_cast<index_t>(v - 1);
    }
  });
}

}  // namespace

double centreOfBox(const double lo[3], const double hi[3], double origin[3]) {
  double extent = 0;
  for (int a = 0; a < 3; ++a) {
    origin[a] = 0.5 * (lo[a] + hi[a]);
    // Squared distances are float: beyond ~1e18 they overflow. Real clouds span far less.
    if (!(hi[a] - lo[a] <= kMaxExtent))
      throw Error("pcl_delaunay_walk: the finite points span " + std::to_string(hi[a] - lo[a]) +
                  " along an axis; at most 1e18 is supported (float squared distances)");
    extent = std::max(extent, hi[a] - lo[a]);
  }
  return extent;
}

bool prepareVertices(const PointView& view, unsigned threads, DelaunayGraph& g) {
  g.input_to_vertex.assign(view.size, kInvalidIndex);
  FinitePoints finite = scanFinite(view, threads);
  if (finite.index.empty()) return false;
  const double extent = centreOfBox(finite.lo, finite.hi, g.origin.data());
  const MortonQuantiser quantiser(g.origin.data(), finite.lo, extent);
  std::vector<MortonItem> items = mortonItems(view, finite.index, quantiser, g, threads);
  freeScratch(finite.index);
  sortItems(items, threads);
  collapseDuplicates(items, threads, g);
  freeScratch(items);
  return true;
}

}  // namespace detail
}  // namespace dw
