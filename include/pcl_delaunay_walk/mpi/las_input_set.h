/// \file las_input_set.h
/// \brief The distributed TIN's input: one LAS file or a pre-split set of LAS files, seen as one sequence
/// of records (the files' records concatenated in the order given). A rank reads any range of that
/// sequence by seeking inside the files that hold it, so no rank reads more than its share whether the
/// cloud is one big file, many tiles, or both; the global index of a point is its position in the
/// sequence (after the class filter), exactly as if the files were one. MPI-free (tests use it directly).
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_reader.h"

namespace dw {
namespace mpi {

/// World coordinates of the triangulation frame: world = frame * scale + offset per axis.
struct Frame {
  double scale[2] = {1, 1}, offset[2] = {0, 0};
};

/// Reads a list of paths: one per line; blank lines and lines starting with '#' are skipped; relative
/// paths are taken relative to the list file's directory. Throws dw::Error if unreadable or empty.
std::vector<std::string> readPathList(const std::string& list_path);

class LasInputSet {
 public:
  /// Opens every file's header (validated). `max_records` > 0 keeps only the first max_records records
  /// of the whole sequence. Throws dw::Error (las::LasError) on a missing or malformed file.
  explicit LasInputSet(std::vector<std::string> paths, std::uint64_t max_records = 0);

  const std::vector<std::string>& paths() const { return paths_; }
  /// Records in the sequence (before any class filter).
  std::uint64_t size() const { return total_; }

  /// The frame in which the exact predicates run. When every file has equal x and y scales and all
  /// files share scale and offset, it is the LAS integers (X, Y as doubles), as dw_tin uses for one
  /// file; otherwise scaled units relative to the first file's offset (x = X * scale_f + (offset_f -
  /// offset_0)), so files with different offsets still share one frame. One rule for every reader, so
  /// the distributed run and any single-process reference see identical numbers.
  const Frame& frame() const { return frame_; }

  /// The boundary nearest to sequence position `index` (<= size()) at which a range should start or
  /// end: `index` itself inside a LAS file, the nearer start of a chunk (or end of the file) inside a
  /// LAZ file, so that no chunk is decoded by two ranks. Non-decreasing in `index`; 0 and size() map
  /// to themselves, so boundaries of consecutive ranges still partition the sequence.
  std::uint64_t alignToChunk(std::uint64_t index) const;

  /// Calls fn(record, frame_x, frame_y, world_z) for every record of [first, last) in sequence order.
  template <class Fn>
  void forEach(std::uint64_t first, std::uint64_t last, Fn&& fn) const;

 private:
  struct FileInfo {
    std::uint64_t first = 0, count = 0;       // position in the sequence, records used
    std::vector<std::uint64_t> chunk_starts;  // LAZ: first record of each chunk in the file; LAS: empty
    double scale[3] = {1, 1, 1}, offset[3] = {0, 0, 0};
  };
  std::vector<std::string> paths_;
  std::vector<FileInfo> files_;
  std::uint64_t total_ = 0;
  bool integer_frame_ = true;
  Frame frame_;
};

template <class Fn>
void LasInputSet::forEach(std::uint64_t first, std::uint64_t last, Fn&& fn) const {
  last = std::min(last, total_);
  std::vector<las::LasRecord> buf;
  for (std::size_t f = 0; f < files_.size() && first < last; ++f) {
    const FileInfo& fi = files_[f];
    if (fi.first + fi.count <= first) continue;
    las::LasReader reader(paths_[f]);
    std::uint64_t at = first - fi.first;
    const std::uint64_t end = std::min(last - fi.first, fi.count);
    reader.seek(at);
    const double dx = fi.offset[0] - files_[0].offset[0], dy = fi.offset[1] - files_[0].offset[1];
    while (at < end) {
      const std::size_t got =
          reader.read(buf, static_cast<std::size_t>(std::min<std::uint64_t>(end - at, 1 << 16)));
      if (got == 0) throw Error(paths_[f] + ": unexpected end of point records");
      for (std::size_t i = 0; i < got; ++i) {
        const las::LasRecord& r = buf[i];
        const double x = integer_frame_ ? double(r.X) : r.X * fi.scale[0] + dx;
        const double y = integer_frame_ ? double(r.Y) : r.Y * fi.scale[1] + dy;
        fn(r, x, y, r.Z * fi.scale[2] + fi.offset[2]);
      }
      at += got;
    }
    first = fi.first + end;
  }
}

}  // namespace mpi
}  // namespace dw
