#include "pcl_delaunay_walk/core/util/point_file.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& why) {
  throw Error("pcl_delaunay_walk: cannot read points from '" + path + "': " + why);
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::size_t typeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

std::vector<double> readKittiBin(const std::string& path) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) fail(path, "cannot open");
  const std::streamoff size = f.tellg();
  if (size % 16 != 0) fail(path, "size is not a multiple of 16 bytes (x y z reflectance floats)");
  std::vector<float> raw(static_cast<std::size_t>(size / 4));
  f.seekg(0);
  f.read(reinterpret_cast<char*>(raw.data()), size);
  std::vector<double> xyz;
  xyz.reserve(raw.size() / 4 * 3);
  for (std::size_t i = 0; i + 3 < raw.size(); i += 4) xyz.insert(xyz.end(), {raw[i], raw[i + 1], raw[i + 2]});
  return xyz;
}

}  // namespace

std::vector<double> readPointsXyz(const std::string& path) {
  if (endsWith(path, ".bin")) return readKittiBin(path);
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "cannot open");
  std::string line;
  if (!std::getline(f, line) || line.rfind("ply", 0) != 0)
    fail(path, "not a PLY file (supported: .ply, KITTI .bin)");
  bool ascii = false, in_vertex = false, seen_format = false;
  std::size_t count = 0, stride = 0, nprops = 0;
  int xi = -1, yi = -1, zi = -1;
  std::vector<std::size_t> offs;
  std::vector<std::string> types;
  while (std::getline(f, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ss(line);
    std::string kw;
    ss >> kw;
    if (kw == "format") {
      std::string fmt;
      ss >> fmt;
      if (fmt == "ascii")
        ascii = true;
      else if (fmt != "binary_little_endian")
        fail(path, "unsupported PLY format '" + fmt + "'");
      seen_format = true;
    } else if (kw == "element") {
      std::string name;
      std::size_t n = 0;
      ss >> name >> n;
      if (in_vertex && name != "vertex") in_vertex = false;
      if (name == "vertex")
        in_vertex = true, count = n;
      else
        in_vertex = false;
    } else if (kw == "property" && in_vertex) {
      std::string type, name;
      ss >> type >> name;
      if (type == "list") fail(path, "list property in vertex element");
      const std::size_t sz = typeSize(type);
      if (sz == 0) fail(path, "unknown property type '" + type + "'");
      if (name == "x") xi = int(nprops);
      if (name == "y") yi = int(nprops);
      if (name == "z") zi = int(nprops);
      offs.push_back(stride);
      types.push_back(type);
      stride += sz;
      ++nprops;
    } else if (kw == "end_header") {
      break;
    }
  }
  if (!seen_format || xi < 0 || yi < 0 || zi < 0) fail(path, "header lacks format or vertex x/y/z");
  // The vertex element must come first for this reader (true for every PLY we ship and the Stanford set).
  // Never trust the header's count for an allocation: it must fit in what the file still holds.
  const std::streamoff here = f.tellg();
  f.seekg(0, std::ios::end);
  const std::uint64_t remaining = static_cast<std::uint64_t>(f.tellg() - here);
  f.seekg(here);
  const std::uint64_t min_bytes_per_vertex = ascii ? 2 * nprops : stride;
  if (count > remaining / std::max<std::uint64_t>(1, min_bytes_per_vertex))
    fail(path, "header claims " + std::to_string(count) + " vertices but the file holds at most " +
                   std::to_string(remaining / std::max<std::uint64_t>(1, min_bytes_per_vertex)));
  std::vector<double> xyz;
  xyz.reserve(count * 3);
  if (ascii) {
    std::vector<double> vals(nprops);
    for (std::size_t i = 0; i < count; ++i) {
      for (std::size_t k = 0; k < nprops; ++k)
        if (!(f >> vals[k])) fail(path, "truncated at vertex " + std::to_string(i));
      xyz.insert(xyz.end(), {vals[xi], vals[yi], vals[zi]});
    }
  } else {
    std::vector<char> rec(stride);
    auto get = [&](int k) -> double {
      const char* p = rec.data() + offs[k];
      if (types[k] == "double" || types[k] == "float64") {
        double d;
        std::memcpy(&d, p, 8);
        return d;
      }
      if (types[k] != "float" && types[k] != "float32") fail(path, "x/y/z must be float or double");
      float v;
      std::memcpy(&v, p, 4);
      return v;
    };
    for (std::size_t i = 0; i < count; ++i) {
      if (!f.read(rec.data(), static_cast<std::streamsize>(stride)))
        fail(path, "truncated at vertex " + std::to_string(i));
      xyz.insert(xyz.end(), {get(xi), get(yi), get(zi)});
    }
  }
  return xyz;
}

}  // namespace dw
