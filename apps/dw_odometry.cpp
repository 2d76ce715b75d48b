// dw_odometry: LiDAR odometry on a sliding-window local map. Each scan is registered onto the map of
// the previous frames' downsampled points (a DynamicDelaunayGraph: exact nearest neighbours), then its
// points go in and points beyond the range, or older than --max-age frames, go out.
//
//   dw_odometry SCAN... --poses OUT.txt [--truth POSES.txt] [--plot PREFIX] [--voxel L=0.5]
//               [--max-range R=100] [--max-age N=0] [--max-distance D=1] [--max-iterations N=30]
//               [--epsilon E=1e-8] [--min-fitness F=0.3] [--threads N=1] [--every N] [--quiet]
//
// Scans: PCD, PLY, KITTI .bin, LAS, LAZ. Poses are in the first scan's frame (KITTI format). The run
// ends with the latency percentiles and the map's insert and remove rates.
#include <cstdio>
#include <string>
#include <vector>

#include "app_args.h"
#include "localize_common.h"
#include "pcl_delaunay_walk/core/registration/sliding_window_odometry.h"

namespace {

struct Options {
  std::vector<std::string> scans;
  std::string poses, truth, plot;
  dw::OdometryOptions odo;
  std::size_t every = 1;
  bool quiet = false;
};

const char* kUsage =
    "usage: dw_odometry SCAN... --poses OUT.txt [--truth POSES.txt] [--plot PREFIX] [--voxel L=0.5]\n"
    "       [--max-range R=100] [--max-age N=0] [--max-distance D=1] [--max-iterations N=30] [--epsilon "
    "E=1e-8]\n"
    "       [--min-fitness F=0.3] [--threads N=1] [--every N=1] [--quiet]\n";

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw dw::Error("missing value for " + a);
      return argv[++i];
    };
    auto number = [&]() { return dw_apps::parseNonNegative(value(), ("value for " + a).c_str()); };
    if (a == "--max-range")
      o.odo.max_range = number();
    else if (a == "--max-age")
      o.odo.max_age = unsigned(dw_apps::parseCount(value(), "--max-age"));
    else if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    } else if (!dw_apps::parseFrameOption(a, value, o, o.odo)) {
      throw dw::Error("unknown option '" + a + "'");
    }
  }
  if (o.scans.empty()) throw dw::Error("no scans");
  if (o.poses.empty()) throw dw::Error("no output (--poses OUT.txt)");
  return o;
}

int run(const Options& o) {
  dw::SlidingWindowOdometry odo(o.odo);
  std::vector<Eigen::Matrix4d> truth =
      o.truth.empty() ? std::vector<Eigen::Matrix4d>{} : dw::readKittiPoses(o.truth);
  // Odometry starts in the first scan's frame: compare with the true poses relative to the first.
  if (!truth.empty()) {
    const Eigen::Matrix4d first_inv = truth[0].inverse();
    for (Eigen::Matrix4d& t : truth) t = first_inv * t;
  }
  std::vector<dw_apps::FrameLog> log;
  std::vector<Eigen::Matrix4d> poses;
  for (std::size_t k = 0; k < o.scans.size(); ++k) {
    dw_apps::FrameLog f;
    f.scan = o.scans[k];
    const std::vector<float> scan = dw_apps::loadXyz(o.scans[k]);
    f.result = odo.registerScan(dw::PointView::fromFloat(scan.data(), scan.size() / 3));
    if (k < truth.size()) dw_apps::attachTruth(f, truth[k]);
    poses.push_back(f.result.pose);
    log.push_back(f);
    if (!o.quiet && (k % o.every == 0 || k + 1 == o.scans.size() || f.result.status != dw::FrameStatus::Ok))
      dw_apps::printFrame(log.back(), k, o.scans.size());
  }
  dw::writeKittiPoses(o.poses, poses);
  std::printf("wrote %zu poses to %s\n", poses.size(), o.poses.c_str());
  dw_apps::printSummary(log);
  const dw::OdometryMapStats& s = odo.mapStats();
  std::printf(
      "local map: %zu points; inserted %llu (%.3g points/s), removed %llu (%.3g points/s), "
      "graph extraction %.3f s in all\n",
      odo.mapSize(), static_cast<unsigned long long>(s.inserted),
      s.insert_seconds > 0 ? double(s.inserted) / s.insert_seconds : 0.0,
      static_cast<unsigned long long>(s.removed),
      s.remove_seconds > 0 ? double(s.removed) / s.remove_seconds : 0.0, s.graph_seconds);
  if (!o.plot.empty()) {
    dw_apps::plotFrames(o.plot, log, "dw_odometry");
    std::printf("plots: %s_latency.png%s\n", o.plot.c_str(),
                truth.empty() ? "" : (" " + o.plot + "_error.png").c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_odometry: %s\n", e.what());
    if (argc < 2) std::fputs(kUsage, stderr);
    return 1;
  }
}
