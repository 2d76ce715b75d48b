#include "file_header_check.h"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace {

constexpr std::size_t kMaxHeaderBytes = 1 << 16;
constexpr std::uint64_t kMaxPoints = std::numeric_limits<std::int32_t>::max();  // PCL indexes with int

[[noreturn]] void fail(const std::string& path, const std::string& why) {
  throw Error("'" + path + "': " + why);
}

std::string lowerExtension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  std::string e = dot == std::string::npos ? std::string() : path.substr(dot + 1);
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

/// A non-negative decimal integer that fills the whole token, or fail.
std::uint64_t count(const std::string& path, const std::string& token, const std::string& what) {
  if (token.empty() || token.size() > 19 || !std::all_of(token.begin(), token.end(), ::isdigit))
    fail(path, what + " '" + token + "' is not a non-negative integer");
  return std::stoull(token);
}

/// Header lines (up to kMaxHeaderBytes) until `last` starts a line; returns the byte offset after it.
std::uint64_t readHeader(std::ifstream& in, const std::string& path, const std::string& last,
                         std::vector<std::string>& lines) {
  std::string line;
  std::uint64_t offset = 0;
  while (std::getline(in, line)) {
    offset += line.size() + 1;
    if (offset > kMaxHeaderBytes) fail(path, "no end of header in its first 64 KiB");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
    if (line.compare(0, last.size(), last) == 0) return offset;
  }
  fail(path, "header ends before its '" + last + "' line (truncated or not a point file)");
}

PointFileHeader checkPcd(std::ifstream& in, const std::string& path, std::uint64_t file_size) {
  std::vector<std::string> lines;
  const std::uint64_t body = readHeader(in, path, "DATA", lines);
  std::vector<std::uint64_t> sizes, counts;
  std::uint64_t width = 0, height = 0, points = 0;
  bool has_width = false, has_height = false, has_points = false;
  std::string data;
  for (const std::string& l : lines) {
    std::istringstream ss(l);
    std::string key, tok;
    ss >> key;
    if (key == "SIZE") {
      while (ss >> tok) sizes.push_back(count(path, tok, "SIZE"));
    } else if (key == "COUNT") {
      while (ss >> tok) counts.push_back(count(path, tok, "COUNT"));
    } else if (key == "WIDTH") {
      ss >> tok, width = count(path, tok, "WIDTH"), has_width = true;
    } else if (key == "HEIGHT") {
      ss >> tok, height = count(path, tok, "HEIGHT"), has_height = true;
    } else if (key == "POINTS") {
      ss >> tok, points = count(path, tok, "POINTS"), has_points = true;
    } else if (key == "DATA") {
      ss >> data;
    }
  }
  if (!has_width || !has_height) fail(path, "PCD header without WIDTH and HEIGHT");
  if (width > kMaxPoints || height > kMaxPoints || width * height > kMaxPoints)
    fail(path, "PCD WIDTH x HEIGHT is larger than a point cloud can be");
  if (!has_points) points = width * height;
  if (points != width * height) fail(path, "PCD POINTS disagrees with WIDTH x HEIGHT");
  if (points == 0) fail(path, "the file holds no points");
  if (sizes.empty()) fail(path, "PCD header without SIZE");
  if (!counts.empty() && counts.size() != sizes.size())
    fail(path, "PCD SIZE and COUNT lists differ in length");
  std::uint64_t point_bytes = 0;
  for (std::size_t k = 0; k < sizes.size(); ++k) {
    const std::uint64_t c = counts.empty() ? 1 : counts[k];
    if (sizes[k] == 0 || sizes[k] > 8 || c > (1u << 20)) fail(path, "PCD field SIZE or COUNT out of range");
    point_bytes += sizes[k] * c;
  }
  if (point_bytes == 0) fail(path, "PCD points have no bytes");
  const std::uint64_t left = file_size - std::min(file_size, body);
  PointFileHeader h{points, 0, false};
  if (data == "binary") {
    if (points * point_bytes > left)
      fail(path, "binary body is shorter than POINTS x point size (truncated)");
    h.point_bytes = point_bytes, h.binary = true;
  } else if (data == "ascii") {
    if (points > left) fail(path, "ASCII body is shorter than one byte per point (truncated)");
  } else if (data == "binary_compressed") {
    // LZF cannot expand a stream by more than ~100x; a header promising more is lying.
    if (points * point_bytes > 128 * left) fail(path, "compressed body is far too short for its POINTS");
    h.point_bytes = point_bytes, h.binary = true;
  } else {
    fail(path, "unknown PCD DATA kind '" + data + "'");
  }
  return h;
}

std::uint64_t plyTypeBytes(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

PointFileHeader checkPly(std::ifstream& in, const std::string& path, std::uint64_t file_size) {
  std::vector<std::string> lines;
  const std::uint64_t body = readHeader(in, path, "end_header", lines);
  if (lines.empty() || lines[0] != "ply") fail(path, "not a PLY file (no 'ply' magic line)");
  std::string format;
  std::uint64_t vertices = 0, vertex_bytes = 0;
  bool in_vertex = false, has_vertex = false, variable = false;
  for (const std::string& l : lines) {
    std::istringstream ss(l);
    std::string key, a, b;
    ss >> key;
    if (key == "format") {
      ss >> format;
    } else if (key == "element") {
      ss >> a >> b;
      in_vertex = a == "vertex";
      if (in_vertex) vertices = count(path, b, "element vertex"), has_vertex = true;
    } else if (key == "property" && in_vertex) {
      ss >> a;
      if (a == "list") {
        variable = true;
      } else {
        const std::uint64_t n = plyTypeBytes(a);
        if (n == 0) fail(path, "unknown PLY property type '" + a + "'");
        vertex_bytes += n;
      }
    }
  }
  if (!has_vertex) fail(path, "PLY header without 'element vertex'");
  if (vertices > kMaxPoints) fail(path, "PLY vertex count is larger than a point cloud can be");
  if (vertices == 0) fail(path, "the file holds no points");
  const std::uint64_t left = file_size - std::min(file_size, body);
  PointFileHeader h{vertices, 0, false};
  if (format == "ascii") {
    if (vertices > left) fail(path, "ASCII body is shorter than one byte per vertex (truncated)");
  } else if (format == "binary_little_endian" || format == "binary_big_endian") {
    const std::uint64_t per = variable ? std::max<std::uint64_t>(vertex_bytes, 1) : vertex_bytes;
    if (per == 0) fail(path, "PLY vertices have no properties");
    if (vertices * per > left) fail(path, "binary body is shorter than its vertices (truncated)");
    h.point_bytes = per, h.binary = true;
  } else {
    fail(path, "unknown PLY format '" + format + "'");
  }
  return h;
}

}  // namespace

PointFileHeader checkPointFileHeader(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) fail(path, "cannot open the file");
  if (!S_ISREG(st.st_mode)) fail(path, "not a regular file");
  const std::uint64_t size = static_cast<std::uint64_t>(st.st_size);
  if (size == 0) fail(path, "the file is empty");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open the file");
  const std::string ext = lowerExtension(path);
  if (ext == "pcd") return checkPcd(in, path, size);
  if (ext == "ply") return checkPly(in, path, size);
  return {};
}

}  // namespace dw
