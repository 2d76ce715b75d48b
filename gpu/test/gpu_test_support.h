// Shared helpers of the GPU tests and the GPU benchmark: device presence, data location, a tiny PCD
// reader (the core reads PLY), random clouds, and host brute force with the device's exact arithmetic.
#pragma once

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#include "pcl_delaunay_walk/gpu/cuda_check.h"

namespace dwgpu_test {

/// Skips the current test where no CUDA device exists (CI has none; the device machine has one).
#define DW_REQUIRE_CUDA_DEVICE()                                                                   \
  do {                                                                                             \
    if (dw::gpu::cudaDeviceCount() == 0)                                                           \
      GTEST_SKIP() << "no CUDA device: GPU tests run on a machine with one (tools/device/run.sh)"; \
  } while (0)

inline bool fileExists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

/// Real data: $DW_GPU_DATA_DIR (the device script points it at a carried copy), else ../shared/data.
inline std::string dataPath(const std::string& rel) {
  const char* env = std::getenv("DW_GPU_DATA_DIR");
  std::string base = env && *env ? env : "";
#ifdef DW_SHARED_DATA_DIR
  if (base.empty()) base = DW_SHARED_DATA_DIR;
#endif
  return base + "/" + rel;
}

#define DW_REQUIRE_DATA(path)                                             \
  do {                                                                    \
    if (!dwgpu_test::fileExists(path))                                    \
      GTEST_SKIP() << "real data not found: " << (path)                   \
                   << " (set DW_GPU_DATA_DIR or provide ../shared/data)"; \
  } while (0)

/// xyz of a PCD file with float x y z fields, DATA ascii or binary (not binary_compressed).
inline std::vector<double> readPcdXyz(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw dw::Error("cannot open " + path);
  std::vector<std::string> fields;
  std::vector<int> sizes;
  std::vector<char> types;
  std::size_t points = 0;
  std::string data, line;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (key == "FIELDS") {
      for (std::string f; ss >> f;) fields.push_back(f);
    } else if (key == "SIZE") {
      for (int s; ss >> s;) sizes.push_back(s);
    } else if (key == "TYPE") {
      for (char t; ss >> t;) types.push_back(t);
    } else if (key == "POINTS") {
      ss >> points;
    } else if (key == "DATA") {
      ss >> data;
      break;
    }
  }
  if (fields.size() != sizes.size() || fields.size() != types.size() || points == 0)
    throw dw::Error("malformed PCD header: " + path);
  int off[3] = {-1, -1, -1}, stride = 0;
  for (std::size_t f = 0; f < fields.size(); ++f) {
    for (int a = 0; a < 3; ++a)
      if (fields[f] == std::string(1, char('x' + a))) {
        if (sizes[f] != 4 || types[f] != 'F') throw dw::Error("PCD xyz must be float32: " + path);
        off[a] = int(f);
      }
  }
  if (off[0] < 0 || off[1] < 0 || off[2] < 0) throw dw::Error("PCD without x y z: " + path);
  std::vector<double> xyz;
  xyz.reserve(points * 3);
  if (data == "ascii") {
    std::vector<double> row(fields.size());
    for (std::size_t i = 0; i < points; ++i) {
      for (auto& v : row)
        if (!(in >> v)) throw dw::Error("truncated PCD: " + path);
      for (int a = 0; a < 3; ++a) xyz.push_back(row[off[a]]);
    }
  } else if (data == "binary") {
    std::vector<int> byte_off(fields.size());
    for (std::size_t f = 0; f < fields.size(); ++f) {
      byte_off[f] = stride;
      stride += sizes[f];
    }
    std::vector<char> buf(points * stride);
    if (!in.read(buf.data(), std::streamsize(buf.size()))) throw dw::Error("truncated PCD: " + path);
    for (std::size_t i = 0; i < points; ++i)
      for (int a = 0; a < 3; ++a) {
        float v;
        std::memcpy(&v, buf.data() + i * stride + byte_off[off[a]], 4);
        xyz.push_back(v);
      }
  } else {
    throw dw::Error("unsupported PCD DATA '" + data + "': " + path);
  }
  return xyz;
}

inline std::vector<double> readXyz(const std::string& path) {
  if (path.size() > 4 && path.substr(path.size() - 4) == ".pcd") return readPcdXyz(path);
  return dw::readPointsXyz(path);
}

/// Squared distance exactly as the device computes it: double, from float coordinates, each operation
/// rounded on its own (the test target is built with -ffp-contract=off).
inline double exactDist2(float px, float py, float pz, float qx, float qy, float qz) {
  const double dx = double(qx) - double(px), dy = double(qy) - double(py), dz = double(qz) - double(pz);
  const double xx = dx * dx, yy = dy * dy, zz = dz * dz;
  const double s = xx + yy;
  return s + zz;
}

inline std::vector<double> randomCloud(std::size_t n, std::uint32_t seed, double scale = 1.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-scale, scale);
  std::vector<double> xyz(3 * n);
  for (auto& v : xyz) v = u(rng);
  return xyz;
}

}  // namespace dwgpu_test
