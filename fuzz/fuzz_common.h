// Helpers shared by the fuzz targets: a check that aborts with a message (libFuzzer then saves the
// input), and the graph-file resealer.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_io.h"

#define DW_FUZZ_CHECK(cond, msg)                                                           \
  do {                                                                                     \
    if (!(cond)) {                                                                         \
      std::fprintf(stderr, "DW_FUZZ_CHECK failed: %s (%s:%d)\n", msg, __FILE__, __LINE__); \
      std::abort();                                                                        \
    }                                                                                      \
  } while (0)

namespace dw_fuzz {

constexpr std::size_t kVersionAt = 8, kFlagsAt = 20, kGraphHeaderSize = 104, kPayloadChecksumAt = 88,
                      kHeaderChecksumAt = 96;

inline void resealGraphFile(std::vector<std::uint8_t>& f) {
  dw::resealGraphFile(f);
}

}  // namespace dw_fuzz
