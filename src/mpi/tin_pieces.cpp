/// \file tin_pieces.cpp
/// \brief Output of the distributed TIN: per-rank binary PLY pieces plus a manifest written last (the
/// only file that claims the pieces are complete), or one PLY gathered on rank 0.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "manifest_file.h"
#include "mpi/fault_injection.h"
#include "pcl_delaunay_walk/core/tin/ply_writer.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"
#include "pcl_delaunay_walk/mpi/distributed_tin.h"

namespace dw {
namespace mpi {
using detail::jsonString;
namespace {

double worldX(const RankTin& t, double x) {
  return x * t.frame.scale[0] + t.frame.offset[0];
}
double worldY(const RankTin& t, double y) {
  return y * t.frame.scale[1] + t.frame.offset[1];
}

/// Position of a gid in a sorted gid list: buckets of the gid range (about one entry each, so the table
/// stays proportional to the list, not to the global point count) narrow a search to a few entries.
class GidIndex {
 public:
  explicit GidIndex(const std::vector<index_t>& gids) : gids_(gids) {
    if (gids.empty()) return;
    lo_ = gids.front();
    const std::uint64_t range = std::uint64_t{gids.back()} - lo_ + 1;
    while ((range >> shift_) > gids.size()) ++shift_;
    start_.assign(static_cast<std::size_t>(range >> shift_) + 2, 0);
    for (index_t g : gids) ++start_[((g - lo_) >> shift_) + 1];
    for (std::size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
  }
  std::size_t find(index_t g) const {
    if (gids_.empty() || g < lo_ || g > gids_.back())
      throw Error("dw::mpi: triangle vertex without coordinates");
    const std::size_t b = (g - lo_) >> shift_;
    const auto first = gids_.begin() + static_cast<std::ptrdiff_t>(start_[b]);
    const auto last = gids_.begin() + static_cast<std::ptrdiff_t>(start_[b + 1]);
    const auto it = std::lower_bound(first, last, g);
    if (it == last || *it != g) throw Error("dw::mpi: triangle vertex without coordinates");
    return static_cast<std::size_t>(it - gids_.begin());
  }

 private:
  const std::vector<index_t>& gids_;
  index_t lo_ = 0;
  unsigned shift_ = 0;
  std::vector<std::size_t> start_;
};

}  // namespace

std::uint64_t writePiece(const std::string& path, const RankTin& t) {
  SafeOutputFile f(path);  // renamed over `path` only once complete
  const std::size_t nv = t.coords.size(), nf = t.emitted.triangles.size() / 3;
  std::ostringstream hdr;
  hdr << "ply\nformat binary_little_endian 1.0\ncomment dw_tin_mpi piece of rank " << t.rank << " of "
      << t.size << "\nelement vertex " << nv
      << "\nproperty double x\nproperty double y\nproperty double z\nproperty uint gid\nelement face " << nf
      << "\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string hs = hdr.str();
  f.write(hs.data(), hs.size());
  std::vector<unsigned char> buf;
  buf.reserve(1 << 20);
  auto flush = [&]() {
    f.write(buf.data(), buf.size());
    buf.clear();
  };
  auto put = [&](const void* p, std::size_t n) {
    const unsigned char* c = static_cast<const unsigned char*>(p);
    buf.insert(buf.end(), c, c + n);
    if (buf.size() >= (1 << 20)) flush();
  };
  for (std::size_t i = 0; i < nv; ++i) {
    const double xyz[3] = {worldX(t, t.coords.x[i]), worldY(t, t.coords.y[i]), t.coords.z[i]};
    put(xyz, sizeof xyz);
    put(&t.coords.gid[i], 4);
  }
  const GidIndex index(t.coords.gid);
  for (std::size_t k = 0; k < nf; ++k) {
    const unsigned char three = 3;
    put(&three, 1);
    for (int c = 0; c < 3; ++c) {
      const std::int32_t local = static_cast<std::int32_t>(index.find(t.emitted.triangles[3 * k + c]));
      put(&local, 4);
    }
  }
  flush();
  f.commit();
  return nv;
}

void writePiecesAndManifest(MPI_Comm comm, const std::string& prefix, const RankTin& t,
                            const DistributedTinOptions& options) {
  const std::string manifest = prefix + ".manifest.json";
  const std::string piece = prefix + ".rank" + std::to_string(t.rank) + ".ply";
  const std::string piece_name =
      piece.substr(piece.find_last_of('/') == std::string::npos ? 0 : piece.find_last_of('/') + 1);
  checkFault(options.inject_fault, t.rank, "write");
  const std::uint64_t mine[2] = {writePiece(piece, t), t.emitted.triangles.size() / 3};
  // The gather is also the barrier: no rank reaches it before its piece is closed.
  std::vector<std::uint64_t> all(2 * static_cast<std::size_t>(t.size));
  MPI_Gather(mine, 2, MPI_UINT64_T, all.data(), 2, MPI_UINT64_T, 0, comm);
  if (t.rank != 0) return;
  std::uint64_t tris = 0;
  std::ostringstream js;
  js << "{\n  \"format\": \"dw_tin_mpi pieces 2\",\n  \"inputs\": [";
  for (std::size_t f = 0; f < options.inputs.size(); ++f)
    js << (f ? ", " : "") << jsonString(options.inputs[f]);
  js << "],\n  \"ranks\": " << t.size << ",\n  \"points\": " << t.total_points << ",\n  \"pieces\": [\n";
  for (int r = 0; r < t.size; ++r) {
    std::string name = piece_name.substr(0, piece_name.rfind(".rank")) + ".rank" + std::to_string(r) + ".ply";
    js << "    {\"file\": " << jsonString(name) << ", \"vertices\": " << all[2 * r]
       << ", \"triangles\": " << all[2 * r + 1] << "}" << (r + 1 < t.size ? "," : "") << "\n";
    tris += all[2 * r + 1];
  }
  js << "  ],\n  \"triangles\": " << tris << ",\n  \"complete\": true\n}\n";
  detail::writeFileAtomically(manifest, js.str());
}

std::vector<index_t> gatherTriangles(MPI_Comm comm, const RankTin& t) {
  const int n = static_cast<int>(t.emitted.triangles.size());
  if (t.emitted.triangles.size() > 0x7fffffffu) throw Error("dw::mpi: too many triangles to gather");
  std::vector<int> counts(t.size), displs(t.size, 0);
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
  std::vector<index_t> all;
  if (t.rank == 0) {
    long long sum = 0;
    for (int r = 0; r < t.size; ++r) displs[r] = static_cast<int>(sum), sum += counts[r];
    if (sum > 0x7fffffff) throw Error("dw::mpi: too many triangles to gather on one rank");
    all.resize(static_cast<std::size_t>(sum));
  }
  MPI_Gatherv(t.emitted.triangles.data(), n, MPI_UINT32_T, all.data(), counts.data(), displs.data(),
              MPI_UINT32_T, 0, comm);
  return all;
}

void writeGathered(MPI_Comm comm, const std::string& path, const RankTin& t,
                   const DistributedTinOptions& options) {
  checkFault(options.inject_fault, t.rank, "write");
  const std::vector<index_t> tris = gatherTriangles(comm, t);
  // Every rank's used vertices, as (gid, x, y, z) records.
  struct V {
    double x, y, z;
    std::uint64_t gid;
  };
  std::vector<V> mine(t.coords.size());
  for (std::size_t i = 0; i < mine.size(); ++i)
    mine[i] = {worldX(t, t.coords.x[i]), worldY(t, t.coords.y[i]), t.coords.z[i], t.coords.gid[i]};
  if (mine.size() * sizeof(V) > 0x7fffffffu) throw Error("dw::mpi: too many vertices to gather");
  const int bytes = static_cast<int>(mine.size() * sizeof(V));
  std::vector<int> counts(t.size), displs(t.size, 0);
  MPI_Gather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
  std::vector<V> all;
  if (t.rank == 0) {
    long long sum = 0;
    for (int r = 0; r < t.size; ++r) displs[r] = static_cast<int>(sum), sum += counts[r];
    if (sum > 0x7fffffff) throw Error("dw::mpi: too many vertices to gather on one rank");
    all.resize(static_cast<std::size_t>(sum) / sizeof(V));
  }
  MPI_Gatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, 0, comm);
  if (t.rank != 0) return;
  // A vertex used by triangles of several ranks arrives once per rank: keep one per gid.
  std::sort(all.begin(), all.end(), [](const V& a, const V& b) { return a.gid < b.gid; });
  all.erase(std::unique(all.begin(), all.end(), [](const V& a, const V& b) { return a.gid == b.gid; }),
            all.end());
  std::vector<index_t> local(tris.size());
  for (std::size_t i = 0; i < tris.size(); ++i)
    local[i] = static_cast<index_t>(
        std::lower_bound(all.begin(), all.end(), tris[i], [](const V& a, index_t g) { return a.gid < g; }) -
        all.begin());
  tin::writeTinPly(path, all.size(),
                   [&](std::size_t i, double* p) {
                     p[0] = all[i].x;
                     p[1] = all[i].y;
                     p[2] = all[i].z;
                   },
                   local.data(), local.size(),
                   {"dw_tin_mpi gathered from " + std::to_string(t.size) + " ranks"});
}

}  // namespace mpi
}  // namespace dw
