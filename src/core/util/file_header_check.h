/// \file file_header_check.h
/// \brief Checks a PCD or PLY file's header against the file before a third-party reader sees it.
#pragma once

#include <cstdint>
#include <string>

namespace dw {

/// What a plausible header promised.
struct PointFileHeader {
  std::uint64_t points = 0;       ///< points (PCD POINTS, PLY element vertex)
  std::uint64_t point_bytes = 0;  ///< bytes per point in a binary body (0 for ASCII bodies)
  bool binary = false;
};

/// Reads the header of a `.pcd` or `.ply` file and throws dw::Error with a clear message when it cannot
/// describe the file: empty file, missing or malformed counts, negative or huge counts, WIDTH x HEIGHT
/// that disagrees with POINTS, zero points, or a body too short for the points it claims (bounded by
/// the file size, so nothing is allocated from a lying header).
///
/// Why: PCL 1.13's readers crash, abort or allocate tens of GiB on such files (docs/robustness.md,
/// B10-B14: empty PCD -> SEGV, WIDTH x HEIGHT wrapping 32 bits -> overrun, PLY vertex count 2^40 ->
/// assertion abort, POINTS 2^32-1 -> 48 GiB). The apps call this before pcl::io::load*File.
/// The extension decides the format (case-insensitive); other extensions are not checked.
PointFileHeader checkPointFileHeader(const std::string& path);

}  // namespace dw
