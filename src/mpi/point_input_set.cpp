/// \file point_input_set.cpp
/// \brief xyz input of the distributed 3D builder: file sets read by range, or a generated cloud.
#include "pcl_delaunay_walk/mpi/point_input_set.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <sstream>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace dw {
namespace mpi {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& why) {
  throw Error(path + ": " + why);
}

unsigned typeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

bool endsWith(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

}  // namespace

PointInputSet::PointInputSet(std::vector<std::string> paths) : paths_(std::move(paths)) {
  if (paths_.empty()) throw Error("dw::mpi: no input files");
  for (const std::string& path : paths_) {
    FileInfo fi;
    fi.first = total_;
    std::ifstream f(path, std::ios::binary | std::ios::ate);
    if (!f) fail(path, "cannot open");
    const std::uint64_t file_size = static_cast<std::uint64_t>(f.tellg());
    f.seekg(0);
    if (endsWith(path, ".bin")) {
      if (file_size % 16 != 0) fail(path, "size is not a multiple of 16 bytes (x y z reflectance floats)");
      fi.kind = 2;
      fi.count = file_size / 16;
      fi.stride = 16;
      fi.off[1] = 4, fi.off[2] = 8;
    } else {
      std::string line;
      if (!std::getline(f, line) || line.rfind("ply", 0) != 0)
        fail(path, "not a PLY file (supported: .ply, KITTI .bin)");
      bool in_vertex = false, first_element = true, fixed = true, seen_format = false;
      int found = 0;
      while (std::getline(f, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream ls(line);
        std::string kw;
        ls >> kw;
        if (kw == "end_header") break;
        if (kw == "format") {
          std::string fmt;
          ls >> fmt;
          if (fmt == "ascii")
            fi.kind = 0;
          else if (fmt == "binary_little_endian")
            fi.kind = 1;
          else
            fail(path, "unsupported PLY format '" + fmt + "'");
          seen_format = true;
        } else if (kw == "element") {
          std::string name;
          std::uint64_t count = 0;
          ls >> name >> count;
          if (name == "vertex") {
            if (!first_element) fail(path, "the vertex element must come first");
            fi.count = count;
          }
          in_vertex = name == "vertex";
          first_element = false;
        } else if (kw == "property" && in_vertex) {
          std::string type, name;
          ls >> type >> name;
          if (type == "list") {
            fixed = false;
            continue;
          }
          const unsigned size = typeSize(type);
          if (size == 0) fail(path, "unknown PLY property type '" + type + "'");
          const int axis = name == "x" ? 0 : name == "y" ? 1 : name == "z" ? 2 : -1;
          if (axis >= 0) {
            if (size < 4 || (size == 4 && type.find("float") == std::string::npos))
              fail(path, "vertex " + name + " must be float or double");
            fi.off[axis] = fi.stride;
            fi.is_double[axis] = size == 8;
            ++found;
          }
          fi.stride += size;
        }
      }
      if (!f || !seen_format || found != 3) fail(path, "header lacks end_header, format or vertex x/y/z");
      fi.data_offset = static_cast<std::uint64_t>(f.tellg());
      if (fi.kind == 1 && !fixed) fi.kind = 0;  // records of varying size: parse the whole file
      if (fi.kind == 1 && fi.data_offset + fi.count * fi.stride > file_size)
        fail(path, "truncated: the header promises more vertices than the file holds");
    }
    files_.push_back(fi);
    total_ += fi.count;
  }
}

PointInputSet PointInputSet::uniform(std::uint64_t n, std::uint64_t seed) {
  PointInputSet s;
  s.uniform_ = true;
  s.uniform_seed_ = seed;
  s.total_ = n;
  return s;
}

std::string PointInputSet::describe() const {
  if (uniform_)
    return std::to_string(total_) + " uniform points (seed " + std::to_string(uniform_seed_) + ")";
  if (paths_.size() == 1) return paths_[0];
  return std::to_string(paths_.size()) + " input files";
}

std::vector<double> PointInputSet::read(std::uint64_t first, std::uint64_t last) const {
  last = std::min(last, total_);
  std::vector<double> xyz;
  if (first >= last) return xyz;
  xyz.reserve(3 * (last - first));
  if (uniform_) {
    for (std::uint64_t i = first; i < last; ++i)
      for (std::uint64_t a = 0; a < 3; ++a)
        xyz.push_back(double(splitmix64((i * 3 + a) ^ (uniform_seed_ << 40)) >> 11) * 0x1p-53);
    return xyz;
  }
  std::vector<unsigned char> buf;
  for (std::size_t k = 0; k < files_.size(); ++k) {
    const FileInfo& fi = files_[k];
    if (fi.first + fi.count <= first || fi.first >= last) continue;
    const std::uint64_t a = std::max(first, fi.first) - fi.first,
                        b = std::min(last, fi.first + fi.count) - fi.first;
    if (fi.kind == 0) {  // no fixed record size: parse all of it, keep the range
      const std::vector<double> all = readPointsXyz(paths_[k]);
      if (all.size() != 3 * fi.count) fail(paths_[k], "vertex count differs from its header");
      xyz.insert(xyz.end(), all.begin() + 3 * a, all.begin() + 3 * b);
      continue;
    }
    std::ifstream f(paths_[k], std::ios::binary);
    if (!f) fail(paths_[k], "cannot open");
    f.seekg(static_cast<std::streamoff>(fi.data_offset + a * fi.stride));
    const std::uint64_t chunk = 1 << 16;
    for (std::uint64_t at = a; at < b;) {
      const std::uint64_t cnt = std::min(chunk, b - at);
      buf.resize(cnt * fi.stride);
      if (!f.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(buf.size())))
        fail(paths_[k], "truncated");
      for (std::uint64_t i = 0; i < cnt; ++i)
        for (int c = 0; c < 3; ++c) {
          const unsigned char* p = buf.data() + i * fi.stride + fi.off[c];
          if (fi.is_double[c]) {
            double v;
            std::memcpy(&v, p, 8);
            xyz.push_back(v);
          } else {
            float v;
            std::memcpy(&v, p, 4);
            xyz.push_back(v);
          }
        }
      at += cnt;
    }
  }
  return xyz;
}

}  // namespace mpi
}  // namespace dw
