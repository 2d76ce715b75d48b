// libFuzzer target: dw::deserializeGraph on arbitrary bytes.
//
// Mode byte 0 (even): the bytes are a file as given; checksums reject almost every mutation, which
// fuzzes the header checks. Mode odd: the checksums are recomputed first (a "resealed" file), so the
// size checks and the structural validation behind them are what must reject the file.
// Either way: a GraphFileError, or a graph that validates, re-serialises to the same header (and to a
// fixed point), and can be searched without crashing or hanging.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "fuzz_common.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool reseal = data[0] & 1;
  std::vector<std::uint8_t> file(data + 1, data + size);
  if (reseal) dw_fuzz::resealGraphFile(file);
  dw::DelaunayGraph g;
  try {
    g = dw::deserializeGraph(file.data(), file.size());
  } catch (const dw::GraphFileError&) {
    return 0;
  }
  g.validate();  // throws (and the fuzzer reports) if the loader let an invalid graph through
  // Unknown header flags are refused (B4), so the writer drops nothing: the header up to its checksums
  // comes back byte for byte, but for the version, which is always the current one (older versions
  // load). The payload may not: loading puts every neighbourhood in shortest-first order (files from
  // before that order are accepted), so the written form must be a fixed point.
  const std::vector<std::uint8_t> again = dw::serializeGraph(g);
  std::uint32_t version = 0;
  std::memcpy(&version, again.data() + dw_fuzz::kVersionAt, 4);
  DW_FUZZ_CHECK(version == dw::kGraphFileVersion, "a graph was not written in the current version");
  const auto after_version = dw_fuzz::kVersionAt + 4;
  DW_FUZZ_CHECK(again.size() == file.size() &&
                    std::equal(file.begin(), file.begin() + dw_fuzz::kVersionAt, again.begin()) &&
                    std::equal(file.begin() + after_version, file.begin() + dw_fuzz::kPayloadChecksumAt,
                               again.begin() + after_version),
                "an accepted file's header or size changed on re-serialisation");
  DW_FUZZ_CHECK(dw::serializeGraph(dw::deserializeGraph(again.data(), again.size())) == again,
                "re-serialising a loaded graph is not a fixed point");

  // A forged graph can be a wrong Delaunay graph (its checksum is honest), so results need not be
  // exact, only well-formed: valid indices, bounded counts, termination.
  auto shared = std::make_shared<const dw::DelaunayGraph>(std::move(g));
  const dw::NeighbourSearch search(shared);
  std::vector<dw::index_t> idx;
  std::vector<float> d2;
  const dw::Vec3f queries[] = {{0, 0, 0}, {1, -2, 3}, {1e6f, 1e6f, -1e6f}};
  for (const dw::Vec3f& q : queries) {
    const dw::WalkResult nn = search.nearest(q, dw::StartStrategy::Zero);
    DW_FUZZ_CHECK(shared->numVertices() == 0 || nn.vertex < shared->numVertices(), "walk left the graph");
    search.knn(q, 8, nn, idx, d2);
    DW_FUZZ_CHECK(idx.size() <= 8, "knn returned more than k");
    for (dw::index_t i : idx) DW_FUZZ_CHECK(i < shared->numInputPoints(), "knn index out of range");
    search.radius(q, 1e30f, nn, idx, d2, 64);
    DW_FUZZ_CHECK(idx.size() <= 64, "radius ignored max_nn");
  }
  return 0;
}
