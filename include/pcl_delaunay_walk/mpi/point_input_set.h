/// \file point_input_set.h
/// \brief Input of the distributed 3D graph builder: xyz points of one file or a pre-split set of files
/// (PLY, KITTI .bin), seen as one sequence (the files' points concatenated in the order given), or a
/// reproducible uniform cloud generated in place. A rank reads any range of the sequence; binary PLY and
/// .bin files are read by seeking to the range, ASCII PLY (whose records have no fixed size) is parsed
/// whole by each rank that needs part of it. The input index of a point is its position in the sequence,
/// as if the files were one. MPI-free.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dw {
namespace mpi {

class PointInputSet {
 public:
  /// Opens every file's header (PLY: ascii or binary_little_endian with the vertex element first;
  /// .bin: KITTI float x y z reflectance). Throws dw::Error on a missing, foreign or truncated file.
  explicit PointInputSet(std::vector<std::string> paths);

  /// `n` points uniform in the unit cube; point i depends only on (i, seed), so every rank makes its own
  /// share without reading anything (scaling runs).
  static PointInputSet uniform(std::uint64_t n, std::uint64_t seed = 1);

  std::uint64_t size() const { return total_; }
  /// For messages: the file, the number of files, or the generator.
  std::string describe() const;
  const std::vector<std::string>& paths() const { return paths_; }

  /// xyz triples of points [first, last) of the sequence (last is clamped to size()).
  std::vector<double> read(std::uint64_t first, std::uint64_t last) const;

 private:
  PointInputSet() = default;
  struct FileInfo {
    std::uint64_t first = 0, count = 0;
    int kind = 0;                      // 0 ascii PLY, 1 binary PLY, 2 KITTI .bin
    std::uint64_t data_offset = 0;     // binary: byte offset of the first vertex
    std::uint32_t stride = 0;          // binary: bytes per vertex
    std::uint32_t off[3] = {0, 0, 0};  // binary: byte offset of x, y, z in a vertex
    bool is_double[3] = {false, false, false};
  };
  std::vector<std::string> paths_;
  std::vector<FileInfo> files_;
  std::uint64_t total_ = 0;
  std::uint64_t uniform_seed_ = 0;
  bool uniform_ = false;
};

}  // namespace mpi
}  // namespace dw
