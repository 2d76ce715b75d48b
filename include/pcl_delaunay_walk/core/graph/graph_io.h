/// \file graph_io.h
/// \brief Versioned binary graph files. Loading is bounds-checked: sizes are checked against the file
/// size before any allocation, the payload checksum is verified, and the structure is validated (one
/// sequential pass per array: offsets monotone, every neighbour index below the vertex count), so a
/// corrupt, truncated or foreign file gives dw::GraphFileError, never a crash or a wrong graph.
/// loadGraph maps the file (private, copy-on-write) and by default the graph's edge records, most of
/// its bytes, are a view of the mapping, kept alive by the graph; the smaller per-vertex arrays are
/// copied into std::vector (their type is shared with code that takes std::vector, the GPU walk's
/// upload among it).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"

namespace dw {

/// The version saveGraph writes. Version 2 differs from 1 only in its payload checksum (per 1 MiB
/// block, so loading verifies on all threads); files of either version load.
constexpr std::uint32_t kGraphFileVersion = 2;
constexpr std::uint32_t kOldestGraphFileVersion = 1;

/// Serialises to bytes / a file. The file is written to a temporary beside `path` and renamed over it
/// once complete (dw::SafeOutputFile): on an I/O failure dw::Error names the file and the reason, and
/// an existing `path` is left as it was.
std::vector<std::uint8_t> serializeGraph(const DelaunayGraph& graph);
void saveGraph(const DelaunayGraph& graph, const std::string& path);

/// Parses bytes / a file. Throws dw::GraphFileError with the reason on any defect.
DelaunayGraph deserializeGraph(const std::uint8_t* data, std::size_t size);
/// Where a loaded graph's edge records live.
enum class GraphStorage {
  Mapped,  ///< a view of the file's private mapping (DelaunayGraph::isMapped()), no copy
  Copied,  ///< copied out of the mapping into owned storage; the mapping is released on return
};

/// Throws GraphFileError naming `path`. With GraphStorage::Mapped the graph keeps the file mapped
/// while its records are a view: the path may then be removed, renamed or replaced (saveGraph
/// renames a new file over it), but the file must not be truncated or rewritten in place by another
/// process (a mapped page past a new end faults; a rewritten page would bypass the checks).
DelaunayGraph loadGraph(const std::string& path, GraphStorage storage = GraphStorage::Mapped);

/// The file format's checksum (64-bit word-wise multiply-xorshift) over n bytes: the header's, and
/// version 1's payload checksum.
std::uint64_t graphFileChecksum(const std::uint8_t* data, std::size_t n);

/// Recomputes both checksums of a serialised graph, by the version its header names, after its bytes
/// were edited (tests and fuzzers use it
/// so that the structural checks, not the checksums, are what meets a forged file). No-op on a buffer
/// shorter than the header.
void resealGraphFile(std::vector<std::uint8_t>& file);

}  // namespace dw
