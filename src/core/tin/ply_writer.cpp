/// \file ply_writer.cpp
/// \brief Buffered binary PLY output (see ply_writer.h).
#include "pcl_delaunay_walk/core/tin/ply_writer.h"

#include <cstring>

namespace dw {
namespace tin {

PlyMeshWriter::PlyMeshWriter(const std::string& path, std::uint64_t num_vertices, std::uint64_t num_faces,
                             const std::vector<std::string>& comments)
    : path_(path), nv_(num_vertices), nf_(num_faces), buf_(1 << 20) {
  if (num_vertices > 0x7FFFFFFFull)
    throw Error(path + ": PLY int32 indices cannot address that many vertices");
  out_.open(path);
  std::string h = "ply\nformat binary_little_endian 1.0\n";
  for (const auto& c : comments) h += "comment " + c + "\n";
  h +=
      "element vertex " + std::to_string(nv_) + "\nproperty double x\nproperty double y\nproperty double z\n";
  h += "element face ";
  if (nf_ == kFacesCountedAtClose) {
    face_count_at_ = h.size();
    face_count_width_ = std::to_string(2 * nv_).size();
    h += std::string(face_count_width_, '0');
  } else {
    h += std::to_string(nf_);
  }
  h += "\nproperty list uchar int vertex_indices\nend_header\n";
  put(h.data(), h.size());
}

PlyMeshWriter::~PlyMeshWriter() = default;  // without close(): the temporary is removed

void PlyMeshWriter::flush() {
  out_.write(buf_.data(), used_);
  used_ = 0;
}

void PlyMeshWriter::put(const void* p, std::size_t n) {
  if (used_ + n > buf_.size()) flush();
  if (n > buf_.size()) {
    out_.write(p, n);
    return;
  }
  std::memcpy(buf_.data() + used_, p, n);
  used_ += n;
}

void PlyMeshWriter::vertex(double x, double y, double z) {
  if (wf_ != 0 || wv_ >= nv_) throw Error(path_ + ": PLY vertex written out of order or beyond the count");
  const double v[3] = {x, y, z};
  put(v, sizeof v);
  ++wv_;
}

void PlyMeshWriter::face(index_t a, index_t b, index_t c) {
  if (wv_ != nv_ || wf_ >= nf_ || (nf_ == kFacesCountedAtClose && wf_ >= 2 * nv_))
    throw Error(path_ + ": PLY face written before all vertices or beyond the count");
  unsigned char rec[13];
  rec[0] = 3;
  const std::int32_t idx[3] = {std::int32_t(a), std::int32_t(b), std::int32_t(c)};
  std::memcpy(rec + 1, idx, 12);
  put(rec, sizeof rec);
  ++wf_;
}

void PlyMeshWriter::close() {
  if (closed_) return;
  const bool counted = nf_ == kFacesCountedAtClose;
  if (wv_ != nv_ || (!counted && wf_ != nf_))
    throw Error(path_ + ": PLY closed with missing vertices or faces");
  flush();
  if (counted) {
    std::string count = std::to_string(wf_);
    count.insert(0, face_count_width_ - count.size(), '0');  // wf_ < 2 nv_: fits the width
    out_.seek(face_count_at_);
    out_.write(count.data(), count.size());
  }
  out_.commit();
  closed_ = true;
}

std::uint64_t writeTinPly(const std::string& path, std::size_t n,
                          const std::function<void(std::size_t, double*)>& xyz, const index_t* triangles,
                          std::size_t num_indices, const std::vector<std::string>& comments) {
  if (num_indices % 3 != 0) throw Error(path + ": triangle array length is not a multiple of 3");
  std::vector<index_t> remap(n, kInvalidIndex);
  for (std::size_t k = 0; k < num_indices; ++k) {
    const index_t v = triangles[k];
    if (v >= n)
      throw Error(path + ": triangle references point " + std::to_string(v) + " of " + std::to_string(n));
    remap[v] = 0;
  }
  index_t next = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (remap[i] == 0) remap[i] = next++;
  PlyMeshWriter w(path, next, num_indices / 3, comments);
  double p[3];
  for (std::size_t i = 0; i < n; ++i)
    if (remap[i] != kInvalidIndex) {
      xyz(i, p);
      w.vertex(p[0], p[1], p[2]);
    }
  for (std::size_t t = 0; t + 2 < num_indices; t += 3)
    w.face(remap[triangles[t]], remap[triangles[t + 1]], remap[triangles[t + 2]]);
  w.close();
  return next;
}

}  // namespace tin
}  // namespace dw
