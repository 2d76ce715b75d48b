/// \file dw_urban_gen.cpp
/// \brief dw_urban_gen: a synthetic localization data set. A procedural city (core/sim/urban_scene.h),
/// a drive through its streets at 10 Hz, an HDL-64-like LiDAR ray-cast at every pose, and a dense
/// prior map sampled on the surfaces: DIR/map.ply (or .pcd, .las), DIR/scans/NNNNNN.bin (KITTI),
/// DIR/poses.txt (KITTI 3x4, map <- sensor), DIR/info.txt. Core-only: no PCL.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <system_error>

#include "app_args.h"
#include "core/sim/replace_file.h"
#include "pcl_delaunay_walk/core/sim/dataset_files.h"
#include "pcl_delaunay_walk/core/sim/lidar_sensor.h"
#include "pcl_delaunay_walk/core/sim/surface_sampler.h"
#include "pcl_delaunay_walk/core/sim/trajectory.h"
#include "pcl_delaunay_walk/core/sim/urban_scene.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void usage(std::FILE* out) {
  std::fprintf(out,
               "usage: dw_urban_gen --out DIR [--seed S] [--scans N] [--map-points M] [options]\n"
               "  Writes a synthetic urban localization data set, the same for the same options:\n"
               "    DIR/map.ply         the dense prior map (points on every visible surface, map frame)\n"
               "    DIR/scans/NNNNNN.bin  KITTI scans: float32 x y z intensity, sensor frame\n"
               "    DIR/poses.txt       the true sensor poses, KITTI 3x4 rows (map <- sensor)\n"
               "    DIR/info.txt        what was generated and how\n"
               "  --seed S              scene, route and noise (1)\n"
               "  --scans N             scans along the drive, 10 Hz (100); 0: none\n"
               "  --map-points M        map size, suffixes k and M (10M); 0: no map\n"
               "  --map-format F        ply (binary), pcd (binary) or las (LAS 1.4, classified) (ply)\n"
               "  --map-noise SIGMA     Gaussian jitter of the map points in metres (0)\n"
               "  --blocks N or NXxNY   city blocks between streets (5x5, 76 m apart)\n"
               "  --speed V             vehicle speed in m/s (8)\n"
               "  --beams B             64: the HDL-64-like model; other B: evenly from +2 to -24.8 deg\n"
               "  --azimuth-steps A     rays per beam and revolution (2083: 0.173 deg)\n"
               "  --max-range R         metres (120)\n"
               "  --range-noise SIGMA   metres (0.02)\n"
               "  --threads T           worker threads (0: all)\n");
}

long long parseInt(const std::string& s, const char* what, long long lo, long long hi) {
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || !end || *end || v < lo || v > hi)
    throw dw::Error(std::string("bad ") + what + " '" + s + "' (expected an integer in [" +
                    std::to_string(lo) + ", " + std::to_string(hi) + "])");
  return v;
}

struct Options {
  std::string out;
  std::string map_format = "ply";
  std::uint64_t seed = 1, scans = 100, map_points = 10000000;
  double map_noise = 0.0;
  unsigned threads = 0;
  dw::sim::UrbanSceneOptions scene;
  dw::sim::TrajectoryOptions drive;
  dw::sim::LidarModel lidar = dw::sim::LidarModel::hdl64();
  std::string command;
};

Options parse(int argc, char** argv) {
  Options o;
  int beams = 64;
  double max_range = o.lidar.max_range, noise = o.lidar.range_noise;
  int azimuth = o.lidar.azimuth_steps;
  for (int i = 0; i < argc; ++i) o.command += (i ? " " : "") + std::string(argv[i]);
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw dw::Error("missing value after " + a);
      return argv[++i];
    };
    if (a == "--out" || a == "-o") {
      o.out = value();
    } else if (a == "--seed") {
      o.seed = static_cast<std::uint64_t>(parseInt(value(), "--seed", 0, (1LL << 62)));
    } else if (a == "--scans") {
      o.scans = static_cast<std::uint64_t>(parseInt(value(), "--scans", 0, 1000000));
    } else if (a == "--map-points") {
      const std::string v = value();
      o.map_points = v == "0" ? 0 : dw_apps::parseCount(v, "--map-points");
      if (o.map_points > 0xFFFFFFFFull) throw dw::Error("--map-points must be below 2^32");
    } else if (a == "--map-format") {
      o.map_format = value();
      if (o.map_format != "ply" && o.map_format != "pcd" && o.map_format != "las")
        throw dw::Error("--map-format must be ply, pcd or las, got '" + o.map_format + "'");
    } else if (a == "--map-noise") {
      o.map_noise = dw_apps::parseNonNegative(value(), "--map-noise");
    } else if (a == "--blocks") {
      const std::string v = value();
      const auto x = v.find('x');
      o.scene.blocks_x = static_cast<int>(parseInt(v.substr(0, x), "--blocks", 1, 200));
      o.scene.blocks_y = x == std::string::npos
                             ? o.scene.blocks_x
                             : static_cast<int>(parseInt(v.substr(x + 1), "--blocks", 1, 200));
    } else if (a == "--speed") {
      o.drive.speed = dw_apps::parseNonNegative(value(), "--speed");
    } else if (a == "--beams") {
      beams = static_cast<int>(parseInt(value(), "--beams", 1, 1024));
    } else if (a == "--azimuth-steps") {
      azimuth = static_cast<int>(parseInt(value(), "--azimuth-steps", 1, 100000));
    } else if (a == "--max-range") {
      max_range = dw_apps::parseNonNegative(value(), "--max-range");
    } else if (a == "--range-noise") {
      noise = dw_apps::parseNonNegative(value(), "--range-noise");
    } else if (a == "--threads") {
      o.threads = static_cast<unsigned>(parseInt(value(), "--threads", 0, 1024));
    } else if (a == "-h" || a == "--help") {
      usage(stdout);
      std::exit(0);
    } else {
      throw dw::Error("unknown option '" + a + "'");
    }
  }
  if (o.out.empty()) throw dw::Error("no output folder (--out DIR)");
  if (o.scans == 0 && o.map_points == 0)
    throw dw::Error("nothing to generate (--scans 0 and --map-points 0)");
  o.scene.seed = o.seed;
  if (beams != 64) o.lidar = dw::sim::LidarModel::uniform(beams, 2.0, -24.8, azimuth);
  o.lidar.azimuth_steps = azimuth;
  o.lidar.max_range = max_range;
  o.lidar.range_noise = noise;
  o.lidar.check();
  return o;
}

/// A folder that exists (created if needed), or a clear error.
void makeFolder(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir))
    throw dw::Error("cannot create the folder " + dir.string() + (ec ? ": " + ec.message() : ""));
}

double seconds(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

void writeInfo(const Options& o, const dw::sim::UrbanScene& scene, const std::string& map_name,
               std::uint64_t scan_points) {
  std::ostringstream s;
  const auto& e = scene.extent();
  const auto& l = o.lidar;
  s << "dw_urban_gen data set (synthetic urban scene, LiDAR drive, prior map)\n"
    << "command: " << o.command << "\nseed: " << o.seed << "\n\n"
    << "frames: the map frame is x east, y north, z up, metres, over [" << e[0] << ", " << e[2] << "] x ["
    << e[1] << ", " << e[3] << "]; the sensor frame is x forward, y left, z up (KITTI Velodyne).\n"
    << "scene: " << o.scene.blocks_x << " x " << o.scene.blocks_y << " blocks, street pitch "
    << scene.streets().pitch << " m, " << scene.primitives().size()
    << " primitives (buildings with facade ledges and pilasters, poles, trees, parked cars).\n";
  if (o.map_points)
    s << map_name << ": " << o.map_points << " points drawn uniformly by area on every visible surface"
      << (o.map_noise > 0 ? ", jittered by " + std::to_string(o.map_noise) + " m" : std::string(", exact"))
      << (o.map_format == "las" ? "; LAS classes 2 ground, 6 building, 5 vegetation, 64 pole, 1 car" : "")
      << ".\n";
  if (o.scans)
    s << "scans/NNNNNN.bin: " << o.scans << " scans, " << scan_points
      << " points in all, KITTI layout (float32 x y z "
      << "intensity, little endian, sensor frame), one revolution each, no motion distortion.\n"
      << "sensor: " << l.elevation_deg.size() << " beams from " << l.elevation_deg.front() << " to "
      << l.elevation_deg.back() << " deg, " << l.azimuth_steps << " azimuth steps, range " << l.min_range
      << "-" << l.max_range << " m, range noise sigma " << l.range_noise << " m, first return only.\n"
      << "poses.txt: the true pose of every scan, one line each, the 3x4 matrix [R | t] row by row (KITTI), "
      << "mapping sensor coordinates into the map frame; " << o.drive.speed << " m/s at " << o.drive.rate_hz
      << " Hz on the street centrelines, " << o.drive.sensor_height << " m above the ground.\n";
  const std::string path = (fs::path(o.out) / "info.txt").string();
  dw::sim::detail::replaceFile(path, [&](std::FILE* f) {
    const std::string text = s.str();
    dw::sim::detail::writeBytes(f, text.data(), text.size(), path);
  });
}

int run(const Options& o) {
  const auto t0 = Clock::now();
  makeFolder(o.out);
  const dw::sim::UrbanScene scene = dw::sim::UrbanScene::generate(o.scene);
  std::fprintf(stderr, "scene: %zu primitives over %.0f x %.0f m\n", scene.primitives().size(),
               scene.extent()[2] - scene.extent()[0], scene.extent()[3] - scene.extent()[1]);
  const std::string map_name = "map." + o.map_format;
  if (o.map_points) {
    const auto tm = Clock::now();
    dw::sim::SurfaceSamplingOptions so;
    so.points = o.map_points;
    so.seed = o.seed;
    so.noise = o.map_noise;
    so.threads = o.threads;
    int last = -1;
    so.progress = [&](double f) {  // by tens, never backwards (a second round of draws re-estimates)
      const int pct = static_cast<int>(100 * f);
      if (pct / 10 <= last / 10) return;
      std::fprintf(stderr, "\rmap: %3d%%", pct);
      last = pct;
    };
    const dw::sim::SurfaceSamples map = dw::sim::sampleSurfaces(scene, so);
    const std::string path = (fs::path(o.out) / map_name).string();
    dw::sim::writeMapCloud(path, map);
    std::fprintf(stderr, "\rmap: %zu points written to %s in %.1f s\n", map.size(), path.c_str(),
                 seconds(tm));
  }
  std::uint64_t scan_points = 0;
  if (o.scans) {
    const auto ts = Clock::now();
    const auto poses = dw::sim::generateTrajectory(scene, o.drive, o.scans, o.seed);
    const fs::path scan_dir = fs::path(o.out) / "scans";
    makeFolder(scan_dir);
    dw::sim::writeKittiPoses((fs::path(o.out) / "poses.txt").string(), poses);
    for (std::size_t k = 0; k < poses.size(); ++k) {
      const dw::sim::LidarScan scan = dw::sim::simulateScan(scene, o.lidar, poses[k], o.seed, k, o.threads);
      char name[32];
      std::snprintf(name, sizeof(name), "%06zu.bin", k);
      dw::sim::writeKittiScan((scan_dir / name).string(), scan);
      scan_points += scan.size();
      if (k + 1 == poses.size() || (k + 1) % 10 == 0)
        std::fprintf(stderr, "\rscans: %zu / %zu (%.0f points per scan, %.2f s per scan)", k + 1,
                     poses.size(), static_cast<double>(scan_points) / (k + 1), seconds(ts) / (k + 1));
    }
    std::fprintf(stderr, "\nscans: %zu written to %s, poses to %s\n", poses.size(), scan_dir.string().c_str(),
                 (fs::path(o.out) / "poses.txt").string().c_str());
  }
  writeInfo(o, scene, map_name, scan_points);
  std::fprintf(stderr, "done in %.1f s: %s\n", seconds(t0), o.out.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  try {
    o = parse(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_urban_gen: %s\n\n", e.what());
    usage(stderr);
    return 2;
  }
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\ndw_urban_gen: %s\n", e.what());
    return 1;
  }
}
