/// \file graph_io.h
/// \brief Versioned binary graph files. Loading is a bounds-checked copy: sizes are checked against the
/// file size before any allocation, the payload checksum is verified, and the structure is validated,
/// so a corrupt, truncated or foreign file gives dw::GraphFileError, never a crash or a wrong graph.
/// loadGraph parses a read-only memory map of the file, so the payload is copied once (into the
/// graph's arrays) and no buffer as large as the file is allocated (the mapped pages are page cache).
/// The graph owns std::vector arrays: a graph that would use the mapping itself as its storage does
/// not exist yet.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"

namespace dw {

constexpr std::uint32_t kGraphFileVersion = 1;

/// Serialises to bytes / a file. The file is written to a temporary beside `path` and renamed over it
/// once complete (dw::SafeOutputFile): on an I/O failure dw::Error names the file and the reason, and
/// an existing `path` is left as it was.
std::vector<std::uint8_t> serializeGraph(const DelaunayGraph& graph);
void saveGraph(const DelaunayGraph& graph, const std::string& path);

/// Parses bytes / a file. Throws dw::GraphFileError with the reason on any defect.
DelaunayGraph deserializeGraph(const std::uint8_t* data, std::size_t size);
/// Throws GraphFileError naming `path`. The file must not be truncated by another process while it
/// loads (a mapped page past a new end would fault).
DelaunayGraph loadGraph(const std::string& path);

/// The file format's checksum (64-bit word-wise multiply-xorshift) over n bytes.
std::uint64_t graphFileChecksum(const std::uint8_t* data, std::size_t n);

/// Recomputes both checksums of a serialised graph after its bytes were edited (tests and fuzzers use it
/// so that the structural checks, not the checksums, are what meets a forged file). No-op on a buffer
/// shorter than the header.
void resealGraphFile(std::vector<std::uint8_t>& file);

}  // namespace dw
