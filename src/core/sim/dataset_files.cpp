// KITTI scans and poses, and the map as PLY, PCD or LAS, all written through replaceFile.
#include "pcl_delaunay_walk/core/sim/dataset_files.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/sim/replace_file.h"
#include "pcl_delaunay_walk/core/las/las_writer.h"

namespace dw {
namespace sim {

namespace {

std::string lowerExtension(const std::string& path) {
  const auto dot = path.find_last_of('.'), slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

void writeText(std::FILE* f, const std::string& text, const std::string& path) {
  detail::writeBytes(f, text.data(), text.size(), path);
}

void writePly(const std::string& path, const SurfaceSamples& map) {
  detail::replaceFile(path, [&](std::FILE* f) {
    writeText(f,
              "ply\nformat binary_little_endian 1.0\ncomment dw_urban_gen prior map (map frame, metres)\n"
              "element vertex " +
                  std::to_string(map.size()) +
                  "\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
              path);
    detail::writeBytes(f, map.xyz.data(), map.xyz.size() * sizeof(float), path);
  });
}

void writePcd(const std::string& path, const SurfaceSamples& map) {
  detail::replaceFile(path, [&](std::FILE* f) {
    const std::string n = std::to_string(map.size());
    writeText(
        f,
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
        "COUNT 1 1 1\nWIDTH " +
            n + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + n + "\nDATA binary\n",
        path);
    detail::writeBytes(f, map.xyz.data(), map.xyz.size() * sizeof(float), path);
  });
}

void writeLas(const std::string& path, const SurfaceSamples& map) {
  las::LasHeader h;
  h.version_minor = 4;  // format 6: class codes beyond 31 (the pole class is user-defined)
  h.point_format = 6;
  h.scale[0] = h.scale[1] = h.scale[2] = 0.001;
  h.software = "dw_urban_gen";
  try {
    las::LasWriter w(path, h);  // a temporary beside path, renamed over it by close()
    las::LasRecord r;
    r.return_number = r.number_of_returns = 1;
    for (std::size_t i = 0; i < map.size(); ++i) {
      for (int c = 0; c < 3; ++c)
        if (!(std::fabs(map.xyz[3 * i + c]) < 2.0e6f))  // int32 at 1 mm, and not NaN
          throw Error("point " + std::to_string(i) + " lies beyond the LAS coordinate range at 1 mm");
      r.X = static_cast<std::int32_t>(std::lround(map.xyz[3 * i] / h.scale[0]));
      r.Y = static_cast<std::int32_t>(std::lround(map.xyz[3 * i + 1] / h.scale[1]));
      r.Z = static_cast<std::int32_t>(std::lround(map.xyz[3 * i + 2] / h.scale[2]));
      r.classification = static_cast<std::uint8_t>(lasClass(map.kind[i]));
      w.write(r);
    }
    w.close();
  } catch (const std::exception& e) {
    throw Error("cannot write " + path + ": " + e.what());
  }
}

}  // namespace

void writeKittiScan(const std::string& path, const LidarScan& scan) {
  detail::replaceFile(path, [&](std::FILE* f) {
    detail::writeBytes(f, scan.xyzi.data(), scan.xyzi.size() * sizeof(float), path);
  });
}

LidarScan readKittiScan(const std::string& path) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) throw Error("cannot read " + path + ": no such file or not readable");
  const std::streamoff size = f.tellg();
  if (size < 0 || size % 16 != 0)
    throw Error("cannot read " + path +
                ": its size is not a multiple of 16 bytes (KITTI x y z intensity floats)");
  LidarScan scan;
  scan.xyzi.resize(static_cast<std::size_t>(size) / 4);
  f.seekg(0);
  if (!f.read(reinterpret_cast<char*>(scan.xyzi.data()), size)) throw Error("cannot read " + path);
  return scan;
}

void writeKittiPoses(const std::string& path, const std::vector<Eigen::Isometry3d>& poses) {
  detail::replaceFile(path, [&](std::FILE* f) {
    char line[512];
    for (const auto& T : poses) {
      const Eigen::Matrix<double, 3, 4> m = T.matrix().topRows<3>();
      int n = 0;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
          n += std::snprintf(line + n, sizeof(line) - n, "%s%.9e", r + c ? " " : "", m(r, c));
      line[n++] = '\n';
      detail::writeBytes(f, line, static_cast<std::size_t>(n), path);
    }
  });
}

std::vector<Eigen::Isometry3d> readKittiPoses(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("cannot read " + path + ": no such file or not readable");
  std::vector<Eigen::Isometry3d> poses;
  std::string line;
  for (std::size_t number = 1; std::getline(f, line); ++number) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream in(line);
    double v[12];
    int n = 0;
    std::string word;
    while (in >> word) {
      char* end = nullptr;
      const double x = std::strtod(word.c_str(), &end);
      if (n == 12 || end != word.c_str() + word.size() || !std::isfinite(x))
        throw Error(path + ":" + std::to_string(number) +
                    ": expected 12 finite numbers (KITTI 3x4 pose), got '" + line + "'");
      v[n++] = x;
    }
    if (n != 12)
      throw Error(path + ":" + std::to_string(number) + ": expected 12 numbers (KITTI 3x4 pose), got " +
                  std::to_string(n));
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) T.matrix()(r, c) = v[4 * r + c];
    const Eigen::Matrix3d R = T.linear();
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-4 || R.determinant() < 0)
      throw Error(path + ":" + std::to_string(number) + ": the 3x3 block is not a rotation");
    poses.push_back(T);
  }
  return poses;
}

unsigned lasClass(SurfaceKind kind) {
  switch (kind) {
    case SurfaceKind::Ground: return 2;
    case SurfaceKind::Building:
    case SurfaceKind::Facade: return 6;
    case SurfaceKind::Trunk:
    case SurfaceKind::Crown: return 5;
    case SurfaceKind::Pole: return 64;
    case SurfaceKind::Car: return 1;
  }
  return 1;
}

void writeMapCloud(const std::string& path, const SurfaceSamples& map) {
  if (map.xyz.size() != 3 * map.kind.size())
    throw Error("cannot write " + path + ": the map has " + std::to_string(map.xyz.size()) +
                " coordinates for " + std::to_string(map.kind.size()) + " points");
  const std::string ext = lowerExtension(path);
  if (ext == "ply") return writePly(path, map);
  if (ext == "pcd") return writePcd(path, map);
  if (ext == "las") return writeLas(path, map);
  throw Error("cannot write " + path + ": unknown map format '." + ext + "' (use .ply, .pcd or .las)");
}

}  // namespace sim
}  // namespace dw
