/// \file localize_common.h
/// \brief What dw_localize and dw_odometry share: reading clouds of every supported format as float
/// xyz, the per-frame log with its summary (latency percentiles, iterations, fitness, errors against
/// true poses), the CSV behind it, and the plots drawn from that CSV by scripts/plot_localization.py.
#pragma once

#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "app_args.h"
#include "core/util/file_header_check.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/registration/kitti_poses.h"
#include "pcl_delaunay_walk/core/registration/localizer.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace dw_apps {

inline bool endsWith(const std::string& s, const std::string& e) {
  if (s.size() < e.size()) return false;
  for (std::size_t i = 0; i < e.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - e.size() + i])) != e[i]) return false;
  return true;
}

/// xyz (3 floats a point) of a PCD, PLY, KITTI .bin, LAS or LAZ file. Throws dw::Error naming it.
inline std::vector<float> loadXyz(const std::string& path) {
  if (!std::ifstream(path).good()) throw dw::Error("cannot open '" + path + "'");
  std::vector<float> out;
  if (endsWith(path, ".pcd")) {
    dw::checkPointFileHeader(path);  // PCL 1.13 crashes on some malformed headers
    pcl::PointCloud<pcl::PointXYZ> cloud;
    if (pcl::io::loadPCDFile(path, cloud) < 0) throw dw::Error("'" + path + "' is not a readable PCD file");
    out.reserve(3 * cloud.size());
    for (const auto& p : cloud) out.insert(out.end(), {p.x, p.y, p.z});
    return out;
  }
  if (endsWith(path, ".las") || endsWith(path, ".laz")) {
    const dw::las::LasCloud las = dw::las::readLasFile(path);
    out.reserve(3 * las.size());
    for (std::size_t i = 0; i < las.size(); ++i)
      out.insert(out.end(), {float(las.x(i)), float(las.y(i)), float(las.z(i))});
    return out;
  }
  const std::vector<double> xyz = dw::readPointsXyz(path);
  out.assign(xyz.begin(), xyz.end());
  return out;
}

/// A pose from "12 numbers" (one argument, spaces or commas) or from the first line of a pose file.
inline Eigen::Matrix4d parsePoseArgument(const std::string& arg) {
  std::string s = arg;
  std::replace(s.begin(), s.end(), ',', ' ');
  std::vector<double> row;
  char* p = &s[0];
  bool numbers = true;
  for (;;) {
    while (*p == ' ' || *p == '\t') ++p;
    if (!*p) break;
    char* end = nullptr;
    const double v = std::strtod(p, &end);
    if (end == p) {
      numbers = false;
      break;
    }
    row.push_back(v);
    p = end;
  }
  if (numbers && !row.empty()) return dw::poseFromKittiRow(row);
  const auto poses = dw::readKittiPoses(arg);
  if (poses.empty()) throw dw::Error("pose file '" + arg + "' has no pose");
  return poses.front();
}

/// The options dw_localize and dw_odometry share, for an app's Options `o` (members scans, poses,
/// truth, plot, every, quiet) and its tracker's options `t` (members icp, voxel, min_fitness,
/// num_threads). `a` is the argument at hand and `value()` takes the next one. Returns false when `a`
/// is none of them; an argument that is not an option is a scan.
template <class AppOptions, class TrackOptions, class Value>
bool parseFrameOption(const std::string& a, Value&& value, AppOptions& o, TrackOptions& t) {
  auto number = [&]() { return parseNonNegative(value(), ("value for " + a).c_str()); };
  if (a == "--poses")
    o.poses = value();
  else if (a == "--truth")
    o.truth = value();
  else if (a == "--plot")
    o.plot = value();
  else if (a == "--max-distance")
    t.icp.max_correspondence_distance = number();
  else if (a == "--max-iterations")
    t.icp.max_iterations = int(parseCount(value(), "--max-iterations"));
  else if (a == "--epsilon")
    t.icp.transformation_epsilon = number();
  else if (a == "--voxel")
    t.voxel = number();
  else if (a == "--min-fitness")
    t.min_fitness = number();
  else if (a == "--threads")
    t.num_threads = unsigned(parseNonNegative(value(), "--threads"));
  else if (a == "--every")
    o.every = parseCount(value(), "--every");
  else if (a == "--quiet")
    o.quiet = true;
  else if (a.empty() || a[0] != '-')
    o.scans.push_back(a);
  else
    return false;
  return true;
}

struct FrameLog {
  std::string scan;
  dw::FrameResult result;
  double t_error = NAN, r_error = NAN;  ///< against the true pose, when given
};

inline double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t k = static_cast<std::size_t>(std::ceil(q * double(v.size()))) - (q > 0 ? 1 : 0);
  return v[std::min(k, v.size() - 1)];
}

/// The frame's translation (m) and rotation (degrees) error against its true pose.
inline void attachTruth(FrameLog& f, const Eigen::Matrix4d& truth) {
  const Eigen::Matrix4d& a = f.result.pose;
  f.t_error = (a.topRightCorner<3, 1>() - truth.topRightCorner<3, 1>()).norm();
  const Eigen::Matrix3d r = a.topLeftCorner<3, 3>().transpose() * truth.topLeftCorner<3, 3>();
  f.r_error = std::acos(std::min(1.0, std::max(-1.0, 0.5 * (r.trace() - 1)))) * 180.0 / M_PI;
}

inline void printFrame(const FrameLog& f, std::size_t k, std::size_t n) {
  const dw::FrameResult& r = f.result;
  std::printf("frame %zu/%zu %-10s it %2d fitness %.3f rmse %.4f points %zu latency %.2f ms", k + 1, n,
              dw::toString(r.status), r.iterations, r.fitness, r.rmse, r.points, 1e3 * r.latency_seconds);
  if (!std::isnan(f.t_error)) std::printf(" err %.4f m %.3f deg", f.t_error, f.r_error);
  std::printf("\n");
}

inline void printSummary(const std::vector<FrameLog>& log) {
  std::vector<double> lat;
  std::map<std::string, std::size_t> statuses;
  double it = 0, fit = 0, ate2 = 0, max_t = 0;
  std::size_t with_truth = 0;
  for (const FrameLog& f : log) {
    lat.push_back(1e3 * f.result.latency_seconds);
    ++statuses[dw::toString(f.result.status)];
    it += f.result.iterations;
    fit += f.result.fitness;
    if (!std::isnan(f.t_error)) {
      ++with_truth;
      ate2 += f.t_error * f.t_error;
      max_t = std::max(max_t, f.t_error);
    }
  }
  const double n = std::max<double>(1, double(log.size()));
  std::printf(
      "frames %zu: latency ms p50 %.2f p95 %.2f p99 %.2f max %.2f; mean iterations %.2f; mean fitness %.4f\n",
      log.size(), percentile(lat, 0.5), percentile(lat, 0.95), percentile(lat, 0.99),
      lat.empty() ? 0.0 : *std::max_element(lat.begin(), lat.end()), it / n, fit / n);
  std::printf("statuses:");
  for (const auto& [s, c] : statuses) std::printf(" %s %zu;", s.c_str(), c);
  std::printf("\n");
  if (with_truth)
    std::printf("against the true poses (%zu frames): ATE (translation RMSE) %.4f m, max %.4f m\n",
                with_truth, std::sqrt(ate2 / double(with_truth)), max_t);
}

/// One row per frame; written through a temporary file renamed over `path`.
inline void writeFrameCsv(const std::string& path, const std::vector<FrameLog>& log) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    if (!f) throw dw::Error("cannot write '" + path + "'");
    f << "frame,latency_ms,iterations,fitness,rmse,points,status,t_error_m,r_error_deg\n";
    for (std::size_t k = 0; k < log.size(); ++k) {
      const dw::FrameResult& r = log[k].result;
      f << k << ',' << 1e3 * r.latency_seconds << ',' << r.iterations << ',' << r.fitness << ',' << r.rmse
        << ',' << r.points << ',' << dw::toString(r.status) << ',';
      if (!std::isnan(log[k].t_error))
        f << log[k].t_error << ',' << log[k].r_error;
      else
        f << ',';
      f << '\n';
    }
    if (!f) throw dw::Error("cannot write '" + path + "'");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) throw dw::Error("cannot write '" + path + "'");
}

/// Writes PREFIX_latency.png (and PREFIX_error.png with true poses) through the plotting script.
inline void plotFrames(const std::string& prefix, const std::vector<FrameLog>& log, const char* title) {
  const std::string csv = prefix + "_frames.csv";
  writeFrameCsv(csv, log);
  const char* env = std::getenv("DW_PLOT_SCRIPT");
  const std::string script = env ? env : DW_PLOT_SCRIPT;
  if (!std::ifstream(script).good())
    throw dw::Error("--plot: the plotting script '" + script + "' is missing (set DW_PLOT_SCRIPT)");
  const char* py = std::getenv("DW_PYTHON");
  const std::string python = py ? py : DW_PLOT_PYTHON;
  const std::string cmd = "'" + python + "' '" + script + "' '" + csv + "' '" + prefix + "' '" + title + "'";
  if (std::system(cmd.c_str()) != 0)
    throw dw::Error("--plot: '" + cmd +
                    "' failed (python3 with matplotlib? DW_PYTHON picks the interpreter)");
}

}  // namespace dw_apps
