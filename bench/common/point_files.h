/// \file point_files.h
/// \brief PCL-free access to the benchmarks' real clouds: finding a file in the shared data, unpacking
/// the gzipped dragons once, and reading xyz from PLY / KITTI .bin (the core reader), PCD (ascii or
/// binary, float x y z among any fields) and LAS/LAZ (the core's reader), so that the peer benchmark
/// runs where PCL is absent (the device machine).
#pragma once

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace dwb {

inline bool fileExists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

/// Finds a real cloud: in $DW_DATA_DIR, else the shared data, else the repository's data/ (which holds
/// a subset). Each candidate is tried for the file itself.
inline std::string findDataFile(const std::string& subdir, const std::string& file) {
  std::vector<std::string> cands;
  if (const char* env = std::getenv("DW_DATA_DIR")) {
    cands.push_back(std::string(env) + "/" + subdir + "/" + file);
    cands.push_back(std::string(env) + "/" + file);
  }
#ifdef DW_SHARED_DATA_DIR
  cands.push_back(std::string(DW_SHARED_DATA_DIR) + "/" + subdir + "/" + file);
#endif
#ifdef DW_TEST_DATA_DIR
  cands.push_back(std::string(DW_TEST_DATA_DIR) + "/" + file);
#endif
  // Targets without those definitions (bench/dw_bench): the checkout this header lives in.
  std::string root = __FILE__;
  for (int up = 0; up < 3; ++up)
    root = root.substr(0, root.find_last_of('/') == std::string::npos ? 0 : root.find_last_of('/'));
  if (!root.empty()) {
    cands.push_back(root + "/../shared/data/" + subdir + "/" + file);
    cands.push_back(root + "/data/" + file);
  }
  // __FILE__ is relative when ccache's base_dir rewrote the compile line; the build folder usually
  // sits in the checkout (<repo>/build-x/bench/dw_bench), so look beside the running executable too.
  char exe_buf[4096];
  const ssize_t exe_len = ::readlink("/proc/self/exe", exe_buf, sizeof exe_buf - 1);
  if (exe_len > 0) {
    std::string dir(exe_buf, static_cast<std::size_t>(exe_len));
    for (int up = 0; up < 3 && dir.find_last_of('/') != std::string::npos; ++up) {
      dir = dir.substr(0, dir.find_last_of('/'));
      if (up >= 1) {
        cands.push_back(dir + "/../shared/data/" + subdir + "/" + file);
        cands.push_back(dir + "/data/" + file);
      }
    }
  }
  for (const auto& c : cands)
    if (fileExists(c)) return c;
  std::string msg = "dw_bench: data file '" + file + "' not found; looked in:";
  for (const auto& c : cands) msg += " " + c;
  throw dw::Error(msg + " (set DW_DATA_DIR to the shared data folder)");
}

/// Where unpacked data goes: $DW_BENCH_CACHE, else <build dir>/bench-data (the build dir is the parent
/// of the running executable's folder: build/bench/dw_bench, build/bench/bench_search).
inline std::string cacheDir() {
  std::string dir;
  if (const char* env = std::getenv("DW_BENCH_CACHE")) {
    dir = env;
  } else {
    char buf[4096];
    const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
    std::string exe = n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string("./x");
    for (int up = 0; up < 2; ++up) {
      const auto slash = exe.find_last_of('/');
      exe = slash == std::string::npos ? std::string(".") : exe.substr(0, slash);
    }
    dir = exe + "/bench-data";
  }
  ::mkdir(dir.c_str(), 0755);
  return dir;
}

/// Gunzips `gz` into the cache once (by name) and returns the unpacked path. Uses the system gzip:
/// the benchmark needs it for two files only, which is not worth a zlib dependency.
inline std::string gunzipToCache(const std::string& gz) {
  std::string base = gz.substr(gz.find_last_of('/') + 1);
  base = base.substr(0, base.size() - 3);
  const std::string out = cacheDir() + "/" + base;
  if (fileExists(out)) return out;
  const std::string tmp = out + ".part" + std::to_string(::getpid());
  const std::string cmd = "gzip -dc '" + gz + "' > '" + tmp + "'";
  if (std::system(cmd.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw dw::Error("dw_bench: could not gunzip '" + gz + "' (is gzip installed?)");
  }
  if (std::rename(tmp.c_str(), out.c_str()) != 0) throw dw::Error("dw_bench: cannot write '" + out + "'");
  return out;
}

inline void appendFinite(std::vector<float>& xyz, double x, double y, double z) {
  if (std::isfinite(x) && std::isfinite(y) && std::isfinite(z))
    xyz.insert(xyz.end(), {static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)});
}

/// xyz of a PCD file's points (DATA ascii or binary; fields x, y, z of TYPE F SIZE 4 and COUNT 1, any
/// other fields skipped). binary_compressed is refused with a message.
inline std::vector<double> readPcdXyz(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw dw::Error("dw_bench: cannot open PCD '" + path + "'");
  std::vector<std::string> fields;
  std::vector<int> sizes, counts;
  std::vector<char> types;
  std::size_t points = 0;
  std::string line, data;
  while (data.empty() && std::getline(f, line)) {
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    std::string w;
    if (key == "FIELDS")
      while (ls >> w) fields.push_back(w);
    else if (key == "SIZE")
      while (ls >> w) sizes.push_back(std::stoi(w));
    else if (key == "TYPE")
      while (ls >> w) types.push_back(w[0]);
    else if (key == "COUNT")
      while (ls >> w) counts.push_back(std::stoi(w));
    else if (key == "POINTS")
      ls >> points;
    else if (key == "DATA")
      ls >> data;
  }
  if (counts.empty()) counts.assign(fields.size(), 1);
  if (data.empty() || sizes.size() != fields.size() || types.size() != fields.size() ||
      counts.size() != fields.size())
    throw dw::Error("dw_bench: '" + path + "' has no valid PCD header");
  int offset[3] = {-1, -1, -1}, column[3] = {-1, -1, -1};
  std::size_t stride = 0, values = 0;
  for (std::size_t k = 0; k < fields.size(); ++k) {
    for (int a = 0; a < 3; ++a)
      if (fields[k] == std::string(1, char('x' + a))) {
        if (sizes[k] != 4 || types[k] != 'F' || counts[k] != 1)
          throw dw::Error("dw_bench: '" + path + "': field " + fields[k] + " is not one float");
        offset[a] = static_cast<int>(stride), column[a] = static_cast<int>(values);
      }
    stride += std::size_t(sizes[k]) * std::size_t(counts[k]);
    values += std::size_t(counts[k]);
  }
  if (offset[0] < 0 || offset[1] < 0 || offset[2] < 0)
    throw dw::Error("dw_bench: '" + path + "' has no x y z fields");
  std::vector<double> xyz(3 * points);
  if (data == "binary") {
    std::vector<char> rec(stride);
    for (std::size_t i = 0; i < points; ++i) {
      if (!f.read(rec.data(), static_cast<std::streamsize>(stride)))
        throw dw::Error("dw_bench: '" + path + "' is truncated at point " + std::to_string(i));
      for (int a = 0; a < 3; ++a) {
        float v;
        std::memcpy(&v, rec.data() + offset[a], 4);
        xyz[3 * i + a] = v;
      }
    }
  } else if (data == "ascii") {
    for (std::size_t i = 0; i < points; ++i) {
      if (!std::getline(f, line))
        throw dw::Error("dw_bench: '" + path + "' is truncated at point " + std::to_string(i));
      std::istringstream ls(line);
      std::vector<double> v(values);
      for (double& x : v) ls >> x;
      for (int a = 0; a < 3; ++a) xyz[3 * i + a] = v[std::size_t(column[a])];
    }
  } else {
    throw dw::Error("dw_bench: '" + path + "': PCD DATA " + data + " is not supported here (ascii, binary)");
  }
  return xyz;
}

/// xyz of any cloud file the benchmarks use, by extension: .pcd, .las/.laz, else PLY / KITTI .bin.
inline std::vector<double> readAnyXyz(const std::string& path) {
  auto ends = [&](const char* e) {
    const std::size_t n = std::strlen(e);
    return path.size() > n && path.compare(path.size() - n, n, e) == 0;
  };
  if (ends(".pcd")) return readPcdXyz(path);
  if (ends(".las") || ends(".laz")) {
    const dw::las::LasCloud c = dw::las::readLasFile(path);
    std::vector<double> xyz(3 * c.size());
    for (std::size_t i = 0; i < c.size(); ++i)
      xyz[3 * i] = c.x(i), xyz[3 * i + 1] = c.y(i), xyz[3 * i + 2] = c.z(i);
    return xyz;
  }
  return dw::readPointsXyz(path);
}

}  // namespace dwb
