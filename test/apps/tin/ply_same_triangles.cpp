/// \file ply_same_triangles.cpp
/// \brief Test helper: whether two binary PLY meshes of dw_tin (double x, y, z; uchar count + int32
/// indices) hold the same triangles as canonical sets. A triangle is named by its vertices'
/// coordinates, rotated to start at the smallest (the orientation kept), so meshes that number their
/// vertices differently (the in-memory PLY keeps used vertices only, the streamed one every point)
/// compare equal exactly when they are the same TIN. Every index must address a vertex.
///   ply_same_triangles a.ply b.ply   -> "same N triangles", exit 0; else a reason, exit 1
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using Point = std::array<double, 3>;
using Triangle = std::array<Point, 3>;

std::vector<Triangle> readTriangles(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::string line;
  std::uint64_t nv = 0, nf = 0;
  bool binary = false;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream ls(line);
    std::string w, e;
    ls >> w;
    if (w == "format") binary = line == "format binary_little_endian 1.0";
    if (w == "element") {
      ls >> e;
      (e == "vertex" ? nv : nf) = std::stoull(ls.str().substr(ls.str().rfind(' ') + 1));
    }
    if (w == "property" && line.find("double") == std::string::npos &&
        line.find("list uchar int") == std::string::npos)
      throw std::runtime_error(path + ": unexpected property: " + line);
  }
  if (!binary || line != "end_header") throw std::runtime_error(path + ": not a binary little-endian PLY");
  std::vector<Point> v(nv);
  if (nv && !in.read(reinterpret_cast<char*>(v.data()), std::streamsize(nv * sizeof(Point))))
    throw std::runtime_error(path + ": short vertex data");
  std::vector<Triangle> t(nf);
  for (std::uint64_t f = 0; f < nf; ++f) {
    unsigned char rec[13];
    if (!in.read(reinterpret_cast<char*>(rec), 13) || rec[0] != 3)
      throw std::runtime_error(path + ": face " + std::to_string(f) + " is short or not a triangle");
    std::int32_t idx[3];
    std::memcpy(idx, rec + 1, 12);
    for (int k = 0; k < 3; ++k) {
      if (idx[k] < 0 || std::uint64_t(idx[k]) >= nv)
        throw std::runtime_error(path + ": face " + std::to_string(f) + " has index " +
                                 std::to_string(idx[k]) + " of " + std::to_string(nv) + " vertices");
      t[f][k] = v[std::size_t(idx[k])];
    }
    std::rotate(t[f].begin(), std::min_element(t[f].begin(), t[f].end()), t[f].end());
  }
  if (in.peek() != std::char_traits<char>::eof()) throw std::runtime_error(path + ": bytes after the faces");
  std::sort(t.begin(), t.end());
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: ply_same_triangles a.ply b.ply\n");
    return 2;
  }
  try {
    const auto a = readTriangles(argv[1]), b = readTriangles(argv[2]);
    if (a.size() != b.size()) {
      std::printf("differ: %zu and %zu triangles\n", a.size(), b.size());
      return 1;
    }
    if (a != b) {
      std::size_t n = 0;
      for (std::size_t i = 0; i < a.size(); ++i) n += a[i] != b[i];
      std::printf("differ: %zu of %zu sorted triangles\n", n, a.size());
      return 1;
    }
    std::printf("same %zu triangles\n", a.size());
    return 0;
  } catch (const std::exception& e) {
    std::printf("error: %s\n", e.what());
    return 1;
  }
}
