// dw_localize: localization of a stream of scans against a prior map. The map's Delaunay graph is built
// once on all threads (or loaded from a .graph file), then every scan is registered onto it by ICP
// from a constant-velocity prediction; the poses are written in the KITTI format.
//
//   dw_localize --map MAP [--map MORE...] [--save-map G.graph] [--init-pose "12 numbers" | POSES.txt]
//               SCAN... --poses OUT.txt [--truth POSES.txt] [--plot PREFIX] [--max-distance D]
//               [--max-iterations N] [--epsilon E] [--voxel L] [--metric point|plane]
//               [--kernel none|huber|cauchy] [--kernel-scale K] [--min-fitness F] [--threads N]
//               [--no-motion-model] [--every N] [--quiet] [--gpu]
//
// Maps and scans: PCD, PLY, KITTI .bin, LAS, LAZ; a map may be a graph file saved with --save-map
// (then it must be the only map). Every frame gets a status (docs/localization.md); the run ends with
// the latency percentiles, iterations, fitness and, with --truth, the error against the true poses.
// --gpu registers on the GPU (dw::gpu::Localizer: the map resident on the device, point-to-point only)
// where the build has the GPU module and the machine a CUDA device; otherwise it stops with a message.
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "app_args.h"
#include "localize_common.h"
#ifdef DW_HAVE_GPU
#include "pcl_delaunay_walk/gpu/localizer.h"
#endif

namespace {

struct Options {
  std::vector<std::string> maps, scans;
  std::string save_map, poses, truth, plot;
  Eigen::Matrix4d init = Eigen::Matrix4d::Identity();
  dw::LocalizerOptions loc;
  std::size_t every = 1;
  bool quiet = false, gpu = false, init_given = false;
};

const char* kUsage =
    "usage: dw_localize --map MAP [--map MORE...] [--save-map G.graph] [--init-pose POSE] SCAN... --poses "
    "OUT.txt\n"
    "       [--truth POSES.txt] [--plot PREFIX] [--max-distance D=1] [--max-iterations N=30] [--epsilon "
    "E=1e-8]\n"
    "       [--voxel L=0] [--metric point|plane] [--kernel none|huber|cauchy] [--kernel-scale K=1]\n"
    "       [--min-fitness F=0.3] [--threads N=0 (all)] [--no-motion-model] [--every N=1] [--quiet] "
    "[--gpu]\n";

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw dw::Error("missing value for " + a);
      return argv[++i];
    };
    auto number = [&]() {
      const std::string v = value();
      return dw_apps::parseNonNegative(v, ("value for " + a).c_str());
    };
    if (a == "--map")
      o.maps.push_back(value());
    else if (a == "--save-map")
      o.save_map = value();
    else if (a == "--init-pose")
      o.init = dw_apps::parsePoseArgument(value()), o.init_given = true;
    else if (a == "--kernel-scale")
      o.loc.icp.kernel_scale = number();
    else if (a == "--no-motion-model")
      o.loc.constant_velocity = false;
    else if (a == "--gpu")
      o.gpu = true;
    else if (a == "--metric") {
      const std::string v = value();
      if (v == "point")
        o.loc.icp.metric = dw::IcpMetric::PointToPoint;
      else if (v == "plane")
        o.loc.icp.metric = dw::IcpMetric::PointToPlane;
      else
        throw dw::Error("bad value '" + v + "' for --metric (point or plane)");
    } else if (a == "--kernel") {
      const std::string v = value();
      if (v == "none")
        o.loc.icp.kernel = dw::RobustKernel::None;
      else if (v == "huber")
        o.loc.icp.kernel = dw::RobustKernel::Huber;
      else if (v == "cauchy")
        o.loc.icp.kernel = dw::RobustKernel::Cauchy;
      else
        throw dw::Error("bad value '" + v + "' for --kernel (none, huber or cauchy)");
    } else if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    } else if (!dw_apps::parseFrameOption(a, value, o, o.loc)) {
      throw dw::Error("unknown option '" + a + "'");
    }
  }
  if (o.maps.empty()) throw dw::Error("no map (--map MAP)");
  if (o.scans.empty() && o.save_map.empty()) throw dw::Error("no scans");
  if (!o.scans.empty() && o.poses.empty()) throw dw::Error("no output (--poses OUT.txt)");
  return o;
}

/// The CPU dw::Localizer or the GPU dw::gpu::Localizer over the map: both load a graph file and build
/// a graph from clouds the same way.
template <class Loc>
Loc makeLocalizer(const Options& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool graph_file = o.maps.size() == 1 && dw_apps::endsWith(o.maps[0], ".graph");
  for (const std::string& m : o.maps)
    if (dw_apps::endsWith(m, ".graph") && !graph_file)
      throw dw::Error("map graph '" + m + "' must be the only --map");
  if (graph_file) {
    Loc loc = Loc::load(o.maps[0], o.loc);
    std::printf("map %s: %zu points, graph loaded in %.3f s\n", o.maps[0].c_str(), loc.mapPoints(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return loc;
  }
  std::vector<float> xyz;
  for (const std::string& m : o.maps) {
    const std::vector<float> part = dw_apps::loadXyz(m);
    xyz.insert(xyz.end(), part.begin(), part.end());
  }
  const auto t1 = std::chrono::steady_clock::now();
  std::printf("map: %zu points from %zu file%s, read in %.3f s\n", xyz.size() / 3, o.maps.size(),
              o.maps.size() == 1 ? "" : "s", std::chrono::duration<double>(t1 - t0).count());
  std::string last;
  int tenth = -1;
  auto progress = [&](const std::string& stage, double f) {
    const int t = int(f * 10);
    if (!o.quiet && (stage != last || t != tenth))
      std::printf("  building: %s %d%%\n", stage.c_str(), 10 * t);
    last = stage, tenth = t;
  };
  Loc loc(dw::PointView::fromFloat(xyz.data(), xyz.size() / 3), o.loc, progress);
  std::printf("map graph: %zu vertices, %zu directed edges, built in %.3f s\n", loc.graph().numVertices(),
              loc.graph().numDirectedEdges(),
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count());
  return loc;
}

template <class Loc>
int track(Loc& loc, const Options& o) {
  if (!o.save_map.empty()) {
    loc.save(o.save_map);
    std::printf("saved the map graph to %s\n", o.save_map.c_str());
  }
  if (o.scans.empty()) return 0;
  const std::vector<Eigen::Matrix4d> truth =
      o.truth.empty() ? std::vector<Eigen::Matrix4d>{} : dw::readKittiPoses(o.truth);
  // Without --init-pose a run with true poses starts at the first of them.
  loc.setPose(o.init_given || truth.empty() ? o.init : truth[0]);
  std::vector<dw_apps::FrameLog> log;
  std::vector<Eigen::Matrix4d> poses;
  for (std::size_t k = 0; k < o.scans.size(); ++k) {
    dw_apps::FrameLog f;
    f.scan = o.scans[k];
    const std::vector<float> scan = dw_apps::loadXyz(o.scans[k]);
    f.result = loc.registerScan(dw::PointView::fromFloat(scan.data(), scan.size() / 3));
    poses.push_back(f.result.pose);
    log.push_back(f);
    if (k < truth.size()) dw_apps::attachTruth(log.back(), truth[k]);
    if (!o.quiet && (k % o.every == 0 || k + 1 == o.scans.size() || f.result.status != dw::FrameStatus::Ok))
      dw_apps::printFrame(log.back(), k, o.scans.size());
  }
  dw::writeKittiPoses(o.poses, poses);
  std::printf("wrote %zu poses to %s\n", poses.size(), o.poses.c_str());
  dw_apps::printSummary(log);
  if (!o.plot.empty()) {
    dw_apps::plotFrames(o.plot, log, "dw_localize");
    std::printf("plots: %s_latency.png%s\n", o.plot.c_str(),
                truth.empty() ? "" : (" " + o.plot + "_error.png").c_str());
  }
  return 0;
}

int run(const Options& o) {
  if (!o.gpu) {
    dw::Localizer loc = makeLocalizer<dw::Localizer>(o);
    return track(loc, o);
  }
#ifdef DW_HAVE_GPU
  if (dw::gpu::cudaDeviceCount() == 0)
    throw dw::Error("--gpu: no CUDA device on this machine (run without --gpu for the CPU path)");
  cudaDeviceProp prop;
  dw::gpu::checkCuda(cudaGetDeviceProperties(&prop, 0), "cudaGetDeviceProperties");
  std::printf("GPU: %s (the ICP runs on the device; point-to-point)\n", prop.name);
  dw::gpu::Localizer loc = makeLocalizer<dw::gpu::Localizer>(o);
  return track(loc, o);
#else
  throw dw::Error("--gpu: this dw_localize was built without CUDA (configure with nvcc and DW_WITH_CUDA=ON)");
#endif
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_localize: %s\n", e.what());
    if (argc < 2) std::fputs(kUsage, stderr);
    return 1;
  }
}
