#include "pcl_delaunay_walk/core/registration/kitti_poses.h"

#include <Eigen/LU>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

Eigen::Matrix4d poseFromKittiRow(const std::vector<double>& row) {
  if (row.size() != 12)
    throw Error("a KITTI pose has 12 numbers (3x4 [R|t] row by row), got " + std::to_string(row.size()));
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      const double v = row[std::size_t(4 * r + c)];
      if (!std::isfinite(v)) throw Error("a KITTI pose has a non-finite number");
      t(r, c) = v;
    }
  const Eigen::Matrix3d rot = t.topLeftCorner<3, 3>();
  if ((rot.transpose() * rot - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-4 ||
      std::fabs(rot.determinant() - 1.0) > 1e-4)
    throw Error("a KITTI pose's 3x3 part is not a rotation");
  return t;
}

std::vector<Eigen::Matrix4d> readKittiPoses(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("cannot open pose file '" + path + "'");
  std::vector<Eigen::Matrix4d> poses;
  std::string line;
  for (std::size_t number = 1; std::getline(f, line); ++number) {
    std::istringstream ss(line);
    std::vector<double> row;
    std::string tok;
    while (ss >> tok) {
      char* end = nullptr;
      const double v = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str() || *end != '\0')
        throw Error("'" + path + "' line " + std::to_string(number) + ": '" + tok + "' is not a number");
      row.push_back(v);
    }
    if (row.empty()) continue;
    try {
      poses.push_back(poseFromKittiRow(row));
    } catch (const Error& e) {
      throw Error("'" + path + "' line " + std::to_string(number) + ": " + e.what());
    }
  }
  return poses;
}

void writeKittiPoses(const std::string& path, const std::vector<Eigen::Matrix4d>& poses) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    if (!f) throw Error("cannot write pose file '" + path + "' (cannot create '" + tmp + "')");
    char buf[64];
    for (const Eigen::Matrix4d& t : poses) {
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) {
          std::snprintf(buf, sizeof buf, "%.17g", t(r, c));
          f << buf << (r == 2 && c == 3 ? '\n' : ' ');
        }
    }
    f.flush();
    if (!f) {
      std::remove(tmp.c_str());
      throw Error("cannot write pose file '" + path + "'");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw Error("cannot write pose file '" + path + "' (rename failed)");
  }
}

}  // namespace dw
