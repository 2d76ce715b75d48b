/// \file ply_writer.h
/// \brief Streaming binary PLY writer for big triangle meshes: vertices and faces go straight from the
/// caller's arrays to the file through one buffer (no mesh object in memory). The mesh goes to a
/// temporary that close() renames over `path` (dw::SafeOutputFile): a writer destroyed without a
/// successful close() leaves an existing `path` as it was.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"

namespace dw {
namespace tin {

class PlyMeshWriter {
 public:
  /// As num_faces: the face count is whatever was written, patched into the header by close(). The
  /// header then holds it zero-padded to the digits of 2 * num_vertices (a triangulation of n points
  /// has fewer than 2n triangles), and `path` must be a regular file (the header is rewritten).
  static constexpr std::uint64_t kFacesCountedAtClose = ~std::uint64_t(0);

  /// Opens `path` and writes a binary little-endian header for `num_vertices` (double x, y, z) and
  /// `num_faces` triangles (uchar count, int32 indices). `comments` become header comment lines.
  PlyMeshWriter(const std::string& path, std::uint64_t num_vertices, std::uint64_t num_faces,
                const std::vector<std::string>& comments = {});
  ~PlyMeshWriter();
  PlyMeshWriter(const PlyMeshWriter&) = delete;
  PlyMeshWriter& operator=(const PlyMeshWriter&) = delete;

  void vertex(double x, double y, double z);
  void face(index_t a, index_t b, index_t c);
  /// Checks that exactly the announced numbers were written, then flushes and renames the finished
  /// file over `path`; throws dw::Error (naming the file and the reason) otherwise.
  void close();

 private:
  void put(const void* p, std::size_t n);
  void flush();
  std::string path_;
  SafeOutputFile out_;
  bool closed_ = false;
  std::uint64_t nv_, nf_, wv_ = 0, wf_ = 0;
  std::uint64_t face_count_at_ = 0;  ///< offset of the padded face count (kFacesCountedAtClose)
  std::size_t face_count_width_ = 0;
  std::vector<unsigned char> buf_;
  std::size_t used_ = 0;
};

/// Writes the TIN of `n` points to `path`, keeping only vertices that some triangle uses (renumbered
/// in input order). xyz(i, out) gives point i's coordinates. Returns the number of vertices written.
std::uint64_t writeTinPly(const std::string& path, std::size_t n,
                          const std::function<void(std::size_t, double*)>& xyz, const index_t* triangles,
                          std::size_t num_indices, const std::vector<std::string>& comments = {});

}  // namespace tin
}  // namespace dw
