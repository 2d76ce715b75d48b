/// \file las_input_set.cpp
/// \brief One LAS file or a pre-split set of them as one sequence of records (las_input_set.h).
#include "pcl_delaunay_walk/mpi/las_input_set.h"

#include <fstream>

namespace dw {
namespace mpi {

std::vector<std::string> readPathList(const std::string& list_path) {
  std::ifstream in(list_path);
  if (!in) throw Error(list_path + ": cannot open the list of input files");
  const std::size_t slash = list_path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? std::string() : list_path.substr(0, slash + 1);
  std::vector<std::string> out;
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos || line[b] == '#') continue;
    const std::size_t e = line.find_last_not_of(" \t\r");
    std::string p = line.substr(b, e - b + 1);
    out.push_back(p[0] == '/' ? p : dir + p);
  }
  if (out.empty()) throw Error(list_path + ": the list of input files is empty");
  return out;
}

LasInputSet::LasInputSet(std::vector<std::string> paths, std::uint64_t max_records)
    : paths_(std::move(paths)) {
  if (paths_.empty()) throw Error("dw::mpi: no input files");
  files_.resize(paths_.size());
  std::uint64_t at = 0;
  for (std::size_t f = 0; f < paths_.size(); ++f) {
    const las::LasReader reader(paths_[f]);  // validates the header against the file size
    const las::LasHeader& h = reader.header();
    FileInfo& fi = files_[f];
    fi.first = at;
    fi.count = h.point_count;
    if (max_records) fi.count = std::min(fi.count, max_records - std::min(max_records, at));
    for (int k = 0; k < 3; ++k) fi.scale[k] = h.scale[k], fi.offset[k] = h.offset[k];
    fi.chunk_starts = reader.chunkStarts();
    at += fi.count;
  }
  total_ = at;
  // LAS integers are one exact frame only if they mean the same thing in every file.
  const FileInfo& f0 = files_[0];
  integer_frame_ = f0.scale[0] == f0.scale[1];
  for (const FileInfo& fi : files_)
    integer_frame_ = integer_frame_ && fi.scale[0] == f0.scale[0] && fi.scale[1] == f0.scale[1] &&
                     fi.offset[0] == f0.offset[0] && fi.offset[1] == f0.offset[1];
  for (int k = 0; k < 2; ++k) {
    frame_.scale[k] = integer_frame_ ? f0.scale[k] : 1.0;
    frame_.offset[k] = f0.offset[k];
  }
}

std::uint64_t LasInputSet::alignToChunk(std::uint64_t index) const {
  if (index >= total_) return total_;
  // The file holding `index` (a file of zero records used holds nothing).
  std::size_t f = 0;
  while (f + 1 < files_.size() && files_[f].first + files_[f].count <= index) ++f;
  const FileInfo& fi = files_[f];
  if (fi.chunk_starts.empty()) return index;
  const std::uint64_t local = index - fi.first;
  const auto next = std::upper_bound(fi.chunk_starts.begin(), fi.chunk_starts.end(), local);
  const std::uint64_t lo = *(next - 1);  // chunk_starts[0] == 0 <= local
  const std::uint64_t hi = next == fi.chunk_starts.end() ? fi.count : std::min(*next, fi.count);
  return fi.first + (local - lo <= hi - local ? lo : hi);
}

}  // namespace mpi
}  // namespace dw
