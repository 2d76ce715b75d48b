/// \file las_crs.cpp
/// \brief Finding the CRS records among a LAS file's VLRs and EVLRs (ASPRS LAS 1.4 R15, 2.5-2.6 and
/// "Georeferencing Information").
#include "pcl_delaunay_walk/core/las/las_crs.h"

#include <cstdio>
#include <cstring>
#include <memory>

#include "pcl_delaunay_walk/core/las/las_reader.h"

namespace dw {
namespace las {

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

template <typename T>
T loadLe(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);  // LAS is little-endian, as is every host this module builds for
  return v;
}

class RecordFile {
 public:
  RecordFile(const std::string& path, std::uint64_t size) : path_(path), size_(size) {
    file_.reset(std::fopen(path.c_str(), "rb"));
    if (!file_) throw LasError(path + ": cannot open for reading");
  }
  void read(std::uint64_t at, std::size_t n, unsigned char* out, const std::string& what) {
    if (at > size_ || n > size_ - at || std::fseek(file_.get(), long(at), SEEK_SET) != 0 ||
        std::fread(out, 1, n, file_.get()) != n)
      throw LasError(path_ + ": " + what + " runs past the end of the file");
  }
  std::uint64_t size() const { return size_; }

 private:
  std::string path_;
  std::uint64_t size_;
  std::unique_ptr<std::FILE, FileCloser> file_;
};

/// Keeps the first record of each CRS kind; `body` holds `length` bytes.
void take(LasCrs& crs, std::uint16_t record_id, const std::vector<unsigned char>& body) {
  if (record_id == 2112 && crs.wkt.empty()) {
    std::size_t n = body.size();
    while (n > 0 && body[n - 1] == 0) --n;
    crs.wkt.assign(reinterpret_cast<const char*>(body.data()), n);
  } else if (record_id == 34735 && crs.geo_keys.empty()) {
    crs.geo_keys.resize(body.size() / 2);
    for (std::size_t i = 0; i < crs.geo_keys.size(); ++i)
      crs.geo_keys[i] = loadLe<std::uint16_t>(body.data() + 2 * i);
  } else if (record_id == 34736 && crs.geo_doubles.empty()) {
    crs.geo_doubles.resize(body.size() / 8);
    for (std::size_t i = 0; i < crs.geo_doubles.size(); ++i)
      crs.geo_doubles[i] = loadLe<double>(body.data() + 8 * i);
  } else if (record_id == 34737 && crs.geo_ascii.empty()) {
    crs.geo_ascii.assign(reinterpret_cast<const char*>(body.data()), body.size());
  }
}

bool isProjectionRecord(const unsigned char* user_id) {
  return std::strncmp(reinterpret_cast<const char*>(user_id), "LASF_Projection", 16) == 0;
}

}  // namespace

LasCrs readLasCrs(const std::string& path) {
  LasHeader h;
  std::uint64_t size = 0;
  {
    LasReader reader(path);  // validates the header (LAS or LAZ) against the file
    h = reader.header();
  }
  {
    std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "rb"));
    if (!f || std::fseek(f.get(), 0, SEEK_END) != 0) throw LasError(path + ": cannot open for reading");
    size = std::uint64_t(std::ftell(f.get()));
  }
  RecordFile file(path, size);
  LasCrs crs;
  std::uint64_t at = h.header_size;
  std::vector<unsigned char> body;
  for (std::uint32_t i = 0; i < h.num_vlrs; ++i) {
    unsigned char head[54];
    const std::string name = "VLR " + std::to_string(i);
    if (at + 54 > h.offset_to_points) throw LasError(path + ": " + name + " runs past the point data offset");
    file.read(at, 54, head, name);
    const std::uint16_t length = loadLe<std::uint16_t>(head + 20);
    if (at + 54 + length > h.offset_to_points)
      throw LasError(path + ": " + name + " runs past the point data offset");
    if (isProjectionRecord(head + 2)) {
      body.resize(length);
      file.read(at + 54, length, body.data(), name);
      take(crs, loadLe<std::uint16_t>(head + 18), body);
    }
    at += 54 + length;
  }
  if (h.version_minor < 4) return crs;
  unsigned char evlr_fields[12];
  file.read(235, 12, evlr_fields, "the EVLR fields of the header");
  at = loadLe<std::uint64_t>(evlr_fields);
  const std::uint32_t count = loadLe<std::uint32_t>(evlr_fields + 8);
  for (std::uint32_t i = 0; i < count && at != 0; ++i) {
    unsigned char head[60];
    const std::string name = "EVLR " + std::to_string(i);
    file.read(at, 60, head, name);
    const std::uint64_t length = loadLe<std::uint64_t>(head + 20);
    if (length > file.size()) throw LasError(path + ": " + name + " runs past the end of the file");
    if (isProjectionRecord(head + 2)) {
      body.resize(std::size_t(length));
      file.read(at + 60, std::size_t(length), body.data(), name);
      take(crs, loadLe<std::uint16_t>(head + 18), body);
    }
    at += 60 + length;
  }
  return crs;
}

}  // namespace las
}  // namespace dw
