/// \file graph_pieces.cpp
/// \brief Output of the distributed graph builder as per-rank pieces plus a manifest written last (the
/// only file that claims completeness), and the reader that assembles the whole graph from them.
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "manifest_file.h"
#include "mpi/fault_injection.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"
#include "pcl_delaunay_walk/mpi/distributed_graph.h"

namespace dw {
namespace mpi {
using detail::jsonString;
namespace {

constexpr char kMagic[8] = {'D', 'W', 'G', 'P', '0', '0', '0', '1'};

/// Fixed part of a piece file; the arrays follow in this order: points, per-vertex original counts,
/// originals, edges.
struct PieceHeader {
  char magic[8];
  std::uint32_t rank, size;
  std::int32_t dimension;
  std::uint32_t pad;
  std::uint64_t input_points, vertices, first_vertex, num_vertices, num_originals, num_edges;
  double origin[3];
};

template <class T>
void readArray(std::ifstream& in, std::vector<T>& v, std::uint64_t n, std::uint64_t bytes_left,
               const std::string& path) {
  if (n > bytes_left / sizeof(T)) throw Error(path + ": truncated or corrupt graph piece");
  v.resize(static_cast<std::size_t>(n));
  if (n && !in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T))))
    throw Error(path + ": truncated graph piece");
}

}  // namespace

std::uint64_t writeGraphPiece(const std::string& path, const RankGraph& part) {
  // A degenerate input was built whole on rank 0: its piece is the whole graph, the others are empty.
  std::vector<Vec3f> fb_points;
  std::vector<index_t> counts, fb_originals;
  EdgeList fb_edges;
  const bool fb = part.gathered_fallback;
  const DelaunayGraph& G = part.fallback;
  if (fb) {
    for (std::size_t v = 0; v < G.numVertices(); ++v)
      for (index_t e = G.offsets[v]; e < G.offsets[v + 1]; ++e)
        if (G.edges[e].j > v) fb_edges.emplace_back(static_cast<index_t>(v), G.edges[e].j);
  }
  const std::vector<Vec3f>& pts = fb ? G.points : part.points;
  const std::vector<index_t>& offs = fb ? G.originals_offsets : part.originals_offsets;
  const std::vector<index_t>& orig = fb ? G.originals : part.originals;
  const EdgeList& edges = fb ? fb_edges : part.edges;
  for (std::size_t v = 0; v + 1 < offs.size(); ++v) counts.push_back(offs[v + 1] - offs[v]);

  PieceHeader h{};
  std::memcpy(h.magic, kMagic, 8);
  h.rank = static_cast<std::uint32_t>(part.rank);
  h.size = static_cast<std::uint32_t>(part.size);
  h.dimension = part.dimension;
  h.input_points = part.input_points;
  h.vertices = part.vertices;
  h.first_vertex = fb ? (part.rank == 0 ? 0 : part.vertices) : part.first_vertex;
  h.num_vertices = pts.size();
  h.num_originals = orig.size();
  h.num_edges = edges.size();
  for (int a = 0; a < 3; ++a) h.origin[a] = fb ? G.origin[a] : part.origin[a];
  if (fb && part.rank != 0) h.num_vertices = h.num_originals = h.num_edges = 0;

  SafeOutputFile f(path);  // renamed over `path` only once complete
  f.write(&h, sizeof h);
  f.write(pts.data(), h.num_vertices * sizeof(Vec3f));
  f.write(counts.data(), h.num_vertices * sizeof(index_t));
  f.write(orig.data(), h.num_originals * sizeof(index_t));
  f.write(edges.data(), h.num_edges * sizeof(edges[0]));
  f.commit();
  return sizeof h + h.num_vertices * 16 + h.num_originals * 4 + h.num_edges * 8;
}

void writeGraphPiecesAndManifest(MPI_Comm comm, const std::string& prefix, const RankGraph& part,
                                 const std::string& input_name, const DistributedGraphOptions& o) {
  const std::string manifest = prefix + ".manifest.json";
  const std::size_t slash = prefix.find_last_of('/');
  const std::string base = slash == std::string::npos ? prefix : prefix.substr(slash + 1);
  checkFault(o.inject_fault, part.rank, "write");
  const std::uint64_t bytes = writeGraphPiece(prefix + ".rank" + std::to_string(part.rank) + ".dwgp", part);
  std::uint64_t mine[3] = {bytes, part.gathered_fallback ? 0 : part.points.size(),
                           part.gathered_fallback ? 0 : part.edges.size()};
  if (part.gathered_fallback && part.rank == 0) mine[1] = part.fallback.numVertices();
  // The gather is also the barrier: no rank reaches it before its piece is closed.
  std::vector<std::uint64_t> all(3 * static_cast<std::size_t>(part.size));
  MPI_Gather(mine, 3, MPI_UINT64_T, all.data(), 3, MPI_UINT64_T, 0, comm);
  if (part.rank != 0) return;
  std::ostringstream js;
  js << "{\n  \"format\": \"dw_graph_mpi pieces 1\",\n  \"input\": " << jsonString(input_name)
     << ",\n  \"ranks\": " << part.size << ",\n  \"input_points\": " << part.input_points
     << ",\n  \"pieces\": [\n";
  for (int r = 0; r < part.size; ++r)
    js << "    {\"file\": " << jsonString(base + ".rank" + std::to_string(r) + ".dwgp")
       << ", \"vertices\": " << all[3 * r + 1] << ", \"edges\": " << all[3 * r + 2] << "}"
       << (r + 1 < part.size ? "," : "") << "\n";
  js << "  ],\n  \"complete\": true\n}\n";
  detail::writeFileAtomically(manifest, js.str());
}

DelaunayGraph readGraphPieces(const std::string& manifest) {
  std::ifstream mf(manifest);
  if (!mf) throw Error(manifest + ": cannot open");
  const std::string js((std::istreambuf_iterator<char>(mf)), std::istreambuf_iterator<char>());
  if (js.find("\"complete\": true") == std::string::npos) throw Error(manifest + ": not complete");
  const std::string dir = manifest.substr(0, manifest.find_last_of('/') + 1);
  std::vector<std::string> files;
  const std::string pat = "\"file\": \"";
  for (std::size_t at = js.find(pat); at != std::string::npos; at = js.find(pat, at + 1)) {
    const std::size_t b = at + pat.size(), e = js.find('"', b);
    files.push_back(dir + js.substr(b, e - b));
  }
  if (files.empty()) throw Error(manifest + ": lists no pieces");
  DelaunayGraph g;
  EdgeList edges;
  std::vector<index_t> counts;
  std::uint64_t input_points = 0, expect_first = 0;
  for (std::size_t r = 0; r < files.size(); ++r) {
    const std::string& path = files[r];
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) throw Error(path + ": cannot open");
    std::uint64_t left = static_cast<std::uint64_t>(in.tellg());
    in.seekg(0);
    PieceHeader h;
    if (left < sizeof h || !in.read(reinterpret_cast<char*>(&h), sizeof h) ||
        std::memcmp(h.magic, kMagic, 8) != 0)
      throw Error(path + ": not a graph piece");
    left -= sizeof h;
    if (h.rank != r || h.size != files.size() || h.first_vertex != expect_first)
      throw Error(path + ": piece out of order or from another run");
    if (r == 0) {
      input_points = h.input_points;
      g.dimension = h.dimension;
      for (int a = 0; a < 3; ++a) g.origin[a] = h.origin[a];
    } else if (h.input_points != input_points || h.dimension != g.dimension) {
      throw Error(path + ": piece from another run");
    }
    std::vector<Vec3f> p;
    std::vector<index_t> c, o;
    EdgeList e;
    readArray(in, p, h.num_vertices, left, path);
    readArray(in, c, h.num_vertices, left -= h.num_vertices * sizeof(Vec3f), path);
    readArray(in, o, h.num_originals, left -= h.num_vertices * sizeof(index_t), path);
    readArray(in, e, h.num_edges, left -= h.num_originals * sizeof(index_t), path);
    g.points.insert(g.points.end(), p.begin(), p.end());
    counts.insert(counts.end(), c.begin(), c.end());
    g.originals.insert(g.originals.end(), o.begin(), o.end());
    edges.insert(edges.end(), e.begin(), e.end());
    expect_first += h.num_vertices;
  }
  g.originals_offsets.assign(1, 0);
  for (index_t c : counts) g.originals_offsets.push_back(g.originals_offsets.back() + c);
  if (g.originals_offsets.back() != g.originals.size()) throw Error(manifest + ": inconsistent originals");
  g.input_to_vertex.assign(input_points, kInvalidIndex);
  for (std::size_t v = 0; v < g.points.size(); ++v)
    for (index_t k = g.originals_offsets[v]; k < g.originals_offsets[v + 1]; ++k) {
      if (g.originals[k] >= input_points) throw Error(manifest + ": input index out of range");
      g.input_to_vertex[g.originals[k]] = static_cast<index_t>(v);
    }
  assembleEdges(g, std::move(edges));
  g.validate();
  return g;
}

}  // namespace mpi
}  // namespace dw
