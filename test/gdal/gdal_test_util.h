/// \file gdal_test_util.h
/// \brief Helpers of the GDAL adapter's tests: opening rasters with GDAL, files as bytes, data paths.
#pragma once

#include <gdal.h>
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace dw_test {

inline std::string sharedData(const std::string& rel) {
  return std::string(DW_SHARED_DATA_DIR) + "/" + rel;
}

inline bool exists(const std::string& path) {
  return std::ifstream(path).good();
}

inline std::string readBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

inline void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

/// A scratch folder under the build tree, emptied first.
inline std::string scratch(const std::string& name) {
  const std::string dir = std::string(DW_BINARY_DIR) + "/test_scratch/gdal_" + name;
  std::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "'").c_str());
  return dir;
}

/// Names in a folder (for "no temporary left behind").
inline std::vector<std::string> listFolder(const std::string& dir) {
  std::vector<std::string> out;
  const std::string list = dir + "/.listing";
  std::system(("ls -A '" + dir + "' > '" + list + "'").c_str());
  std::ifstream f(list);
  for (std::string s; std::getline(f, s);)
    if (s != ".listing") out.push_back(s);
  return out;
}

/// A raster opened read-only with GDAL, closed on scope exit.
struct Raster {
  GDALDatasetH ds = nullptr;
  explicit Raster(const std::string& path) {
    GDALAllRegister();
    ds = GDALOpen(path.c_str(), GA_ReadOnly);
  }
  ~Raster() {
    if (ds) GDALClose(ds);
  }
  std::vector<double> values() const {
    const int w = GDALGetRasterXSize(ds), h = GDALGetRasterYSize(ds);
    std::vector<double> v(std::size_t(w) * std::size_t(h));
    EXPECT_EQ(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Read, 0, 0, w, h, v.data(), w, h, GDT_Float64, 0, 0),
              CE_None);
    return v;
  }
};

}  // namespace dw_test
