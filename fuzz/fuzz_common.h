// Helpers shared by the fuzz targets: a check that aborts with a message (libFuzzer then saves the
// input), and the graph-file resealer.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#define DW_FUZZ_CHECK(cond, msg)                                                           \
  do {                                                                                     \
    if (!(cond)) {                                                                         \
      std::fprintf(stderr, "DW_FUZZ_CHECK failed: %s (%s:%d)\n", msg, __FILE__, __LINE__); \
      std::abort();                                                                        \
    }                                                                                      \
  } while (0)

namespace dw_fuzz {

/// Bugs already reported (see docs/robustness.md, "Known bugs") are stepped around by default so that a
/// fuzz run keeps searching for new ones; DW_FUZZ_KNOWN_BUGS=report makes the harnesses hit them again
/// (to check a fix). Their failing tests live in test/robustness.
inline bool reportKnownBugs() {
  static const bool report = [] {
    const char* v = std::getenv("DW_FUZZ_KNOWN_BUGS");
    return v != nullptr && std::strcmp(v, "report") == 0;
  }();
  return report;
}

/// The graph file checksum of graph_io.cpp (format version 1), recomputed over a mutated file so the
/// fuzzer reaches the checks behind it. test/robustness checks that it matches real files.
inline std::uint64_t graphChecksum(const std::uint8_t* p, std::size_t n) {
  std::uint64_t h = 0x9E3779B97F4A7C15ULL ^ n;
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, p + i, 8);
    h = (h ^ w) * 0xff51afd7ed558ccdULL;
    h ^= h >> 29;
  }
  for (; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ULL;
  h ^= h >> 33;
  h *= 0xc4ceb9fe1a85ec53ULL;
  return h ^ (h >> 33);
}

constexpr std::size_t kFlagsAt = 20, kGraphHeaderSize = 104, kPayloadChecksumAt = 88, kHeaderChecksumAt = 96;

inline void resealGraphFile(std::vector<std::uint8_t>& f) {
  if (f.size() < kGraphHeaderSize) return;
  const std::uint64_t payload = graphChecksum(f.data() + kGraphHeaderSize, f.size() - kGraphHeaderSize);
  std::memcpy(f.data() + kPayloadChecksumAt, &payload, 8);
  const std::uint64_t header = graphChecksum(f.data(), kHeaderChecksumAt);
  std::memcpy(f.data() + kHeaderChecksumAt, &header, 8);
}

}  // namespace dw_fuzz
