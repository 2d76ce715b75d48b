/// \file viewer_options.h
/// \brief Command line of dw_viewer: what to show (ICP, TIN or a localization run), how to run ICP, and the
/// screenshot mode. Parsing is strict (a typo must not silently change the demo) and throws dw::Error.
#pragma once

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/search/start_strategy.h"

namespace dw_viewer {

enum class Mode { Icp, Tin, Localization };

struct ViewerOptions {
  Mode mode = Mode::Icp;
  std::string source;  ///< ICP: the cloud that moves
  std::string target;  ///< ICP: the reference whose Delaunay graph is walked
  std::string tin;     ///< TIN: a mesh PLY (from dw_tin) or a cloud to triangulate here

  // Localization / odometry run.
  std::string map;                  ///< the prior (or accumulated) map
  std::string scan;                 ///< the scan of frame `frame`, in its sensor frame
  std::string poses;                ///< estimated poses, KITTI 3x4 rows (map <- sensor)
  std::string truth;                ///< optional true poses, same format
  std::int64_t frame = -1;          ///< -1: the number of the scan's file name (000050.bin: 50), else 0
  double distance_scale = 0.5;      ///< distance to the map at the end of the colour ramp (m)
  std::size_t map_shown = 1500000;  ///< most map points drawn (every n-th beyond)

  // ICP, with stock PCL's defaults where PCL has one (so the run matches pcl::IterativeClosestPoint).
  int max_iterations = 30;
  double max_correspondence_distance = std::sqrt(std::numeric_limits<double>::max());
  double transformation_epsilon = 0.0;
  double euclidean_fitness_epsilon = -std::numeric_limits<double>::max();
  dw::StartStrategy start = dw::StartStrategy::PnnOptimized;
  dw::BuilderType builder = dw::BuilderType::Auto;
  int las_class = -1;  ///< LAS inputs: keep only this classification (2 = ground); -1 keeps all
  unsigned threads = 0;
  /// Rigid motion applied to the source before ICP: tx ty tz (cloud units), roll pitch yaw (degrees).
  /// Lets the demo run on one cloud against itself.
  std::array<double, 6> perturb{{0, 0, 0, 0, 0, 0}};

  // Display.
  std::string screenshot;  ///< non-empty: render without interaction, write this PNG, exit
  int iterations = -1;     ///< screenshot: ICP iterations to run first (-1: to the end, or 0 with --keys)
  int width = 1280, height = 800;
  std::int64_t pick_target = -1;     ///< show the Delaunay edges of this target point (seed Fig. 4)
  std::int64_t walk_source = -1;     ///< show the walk path of this source point
  bool focus = false;                ///< aim the camera at the --pick / --walk overlays
  bool show_graph = false;           ///< draw the whole target graph (small clouds only)
  std::size_t graph_limit = 400000;  ///< most undirected edges drawn for the whole graph
  std::size_t max_lines = 4000;      ///< most correspondence lines drawn (every n-th otherwise)
  bool show_correspondences = true;
  int walk_scale = 8;  ///< walk length drawn in the last colour of the scale (and beyond)
  double point_size = 2.0;
  /// Screenshot mode: keys pressed (through the same handler as interactive ones) before the
  /// picture, e.g. n,n,z,space: a scripted demo, and how the tests reach the key handling.
  std::vector<std::string> keys;
  bool help = false;
};

/// One-paragraph usage text (printed on --help and after a command-line error).
inline const char* usageText() {
  return "usage: dw_viewer SOURCE TARGET [options]     ICP with the Delaunay walk, step by step\n"
         "       dw_viewer --tin MESH_OR_CLOUD [options] a TIN (PLY from dw_tin, or a cloud to triangulate)\n"
         "       dw_viewer --map MAP --scan SCAN --poses EST.txt [--truth TRUE.txt] [--frame K] [options]\n"
         "                                               a localization or odometry run at frame K\n"
         "clouds: .pcd, .ply (x, y, z of any numeric type) or .las/.laz (LAS 1.0-1.4, LAZ); maps and\n"
         "        scans also KITTI .bin. Poses: KITTI 3x4 rows, map <- sensor\n"
         "  --las-class C             LAS inputs: keep only class C (2 = ground)\n"
         "ICP:\n"
         "  --max-iterations N        ICP iteration limit (30)\n"
         "  --max-distance D          correspondence distance limit (none)\n"
         "  --transformation-epsilon E  --fitness-epsilon E   stock PCL convergence criteria\n"
         "  --start S                 walk start: zero, kd-ann, pnn, pnn-optimized (default)\n"
         "  --builder B               graph builder: auto, qhull, incremental\n"
         "  --threads T               search threads (0: all)\n"
         "  --perturb tx,ty,tz,roll,pitch,yaw   move the source first (degrees)\n"
         "localization:\n"
         "  --frame K                 the pose of SCAN: line K of the pose files, from 0 (default: the\n"
         "                            number of SCAN's name, as in scans/000050.bin, else 0)\n"
         "  --distance-scale D        distance to the map at the red end of the colours, metres (0.5)\n"
         "  --map-shown N             most map points drawn, every n-th beyond (1500000)\n"
         "display:\n"
         "  --screenshot OUT.png      render without interaction, write the PNG, exit\n"
         "  --iterations N            with --screenshot: ICP iterations to run first (default: all; 0 with "
         "--keys)\n"
         "  --size WxH                window / image size (1280x800)\n"
         "  --pick I                  show the Delaunay edges of target point I\n"
         "  --walk I                  show the walk of source point I in the current iteration\n"
         "                            (I counts the finite points of the file, in file order)\n"
         "  --focus                   aim the camera at the --pick / --walk overlays\n"
         "  --graph                   draw the whole target graph (at most --graph-limit edges)\n"
         "  --graph-limit N           (400000)\n"
         "  --max-lines N             correspondence lines drawn, every n-th beyond (4000)\n"
         "  --no-correspondences      do not draw correspondence lines\n"
         "  --walk-scale N            walk length of the last colour (8)\n"
         "  --point-size P            (2)\n"
         "  --keys K1,K2,...          with --screenshot: press these keys first (n, space, z, m, t, k)\n"
         "keys: n step, space play/pause, z reset, m correspondences, t whole graph, k clear picks,\n"
         "      shift+click a target point: its Delaunay edges; a source point: its walk\n";
}

namespace detail {

inline double parseNumber(const std::string& flag, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v))
    throw dw::Error("dw_viewer: " + flag + " expects a finite number, got '" + text + "'");
  return v;
}

inline long long parseInteger(const std::string& flag, const std::string& text, long long lo, long long hi) {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || v < lo || v > hi)
    throw dw::Error("dw_viewer: " + flag + " expects an integer in [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "], got '" + text + "'");
  return v;
}

inline std::vector<std::string> splitList(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::string::size_type begin = 0;
  for (;;) {
    const auto end = text.find(sep, begin);
    parts.push_back(text.substr(begin, end == std::string::npos ? std::string::npos : end - begin));
    if (end == std::string::npos) break;
    begin = end + 1;
  }
  return parts;
}

/// The frame a scan's file name gives (KITTI and dw_urban_gen name scans 000050.bin): its base name
/// without the extension, when that is all digits; else 0.
inline std::int64_t frameOfFileName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  std::string base = path.substr(slash == std::string::npos ? 0 : slash + 1);
  base = base.substr(0, base.find('.'));
  if (base.empty() || base.size() > 12 || base.find_first_not_of("0123456789") != std::string::npos) return 0;
  return std::stoll(base);
}

inline dw::BuilderType parseBuilder(const std::string& text) {
  if (text == "auto") return dw::BuilderType::Auto;
  if (text == "qhull") return dw::BuilderType::Qhull;
  if (text == "incremental") return dw::BuilderType::Incremental;
  throw dw::Error("dw_viewer: --builder expects auto, qhull or incremental, got '" + text + "'");
}

}  // namespace detail

/// Parses argv (argv[0] is the program). Throws dw::Error naming the offending argument.
inline ViewerOptions parseViewerOptions(int argc, const char* const* argv) {
  ViewerOptions o;
  std::vector<std::string> positional;
  bool mesh_mode = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw dw::Error("dw_viewer: " + arg + " needs a value");
      return argv[++i];
    };
    constexpr long long kIntMax = std::numeric_limits<int>::max();
    if (arg == "-h" || arg == "--help") {
      o.help = true;
    } else if (arg == "--tin") {
      mesh_mode = true;
      o.tin = value();
    } else if (arg == "--map") {
      o.map = value();
    } else if (arg == "--scan") {
      o.scan = value();
    } else if (arg == "--poses") {
      o.poses = value();
    } else if (arg == "--truth") {
      o.truth = value();
    } else if (arg == "--frame") {
      o.frame = detail::parseInteger(arg, value(), 0, std::numeric_limits<std::int64_t>::max());
    } else if (arg == "--distance-scale") {
      o.distance_scale = detail::parseNumber(arg, value());
      if (!(o.distance_scale > 0 && o.distance_scale <= 1000))
        throw dw::Error("dw_viewer: --distance-scale must be in (0, 1000] metres");
    } else if (arg == "--map-shown") {
      o.map_shown = static_cast<std::size_t>(detail::parseInteger(arg, value(), 1, 1LL << 40));
    } else if (arg == "--las-class") {
      o.las_class = static_cast<int>(detail::parseInteger(arg, value(), 0, 255));
    } else if (arg == "--max-iterations") {
      o.max_iterations = static_cast<int>(detail::parseInteger(arg, value(), 1, kIntMax));
    } else if (arg == "--max-distance") {
      o.max_correspondence_distance = detail::parseNumber(arg, value());
      if (!(o.max_correspondence_distance > 0)) throw dw::Error("dw_viewer: --max-distance must be > 0");
    } else if (arg == "--transformation-epsilon") {
      o.transformation_epsilon = detail::parseNumber(arg, value());
      if (o.transformation_epsilon < 0) throw dw::Error("dw_viewer: --transformation-epsilon must be >= 0");
    } else if (arg == "--fitness-epsilon") {
      o.euclidean_fitness_epsilon = detail::parseNumber(arg, value());
    } else if (arg == "--start") {
      o.start = dw::parseStartStrategy(value());
    } else if (arg == "--builder") {
      o.builder = detail::parseBuilder(value());
    } else if (arg == "--threads") {
      o.threads = static_cast<unsigned>(detail::parseInteger(arg, value(), 0, 1024));
    } else if (arg == "--perturb") {
      const std::string text = value();
      const auto parts = detail::splitList(text, ',');
      if (parts.size() != 6)
        throw dw::Error("dw_viewer: --perturb expects tx,ty,tz,roll,pitch,yaw (6 numbers), got '" + text +
                        "'");
      for (std::size_t k = 0; k < 6; ++k) o.perturb[k] = detail::parseNumber(arg, parts[k]);
    } else if (arg == "--screenshot") {
      o.screenshot = value();
      if (o.screenshot.empty()) throw dw::Error("dw_viewer: --screenshot needs a file name");
    } else if (arg == "--iterations") {
      o.iterations = static_cast<int>(detail::parseInteger(arg, value(), 0, kIntMax));
    } else if (arg == "--size") {
      const std::string text = value();
      const auto parts = detail::splitList(text, 'x');
      if (parts.size() != 2) throw dw::Error("dw_viewer: --size expects WxH, got '" + text + "'");
      o.width = static_cast<int>(detail::parseInteger(arg, parts[0], 64, 8192));
      o.height = static_cast<int>(detail::parseInteger(arg, parts[1], 64, 8192));
    } else if (arg == "--pick") {
      o.pick_target = detail::parseInteger(arg, value(), 0, std::numeric_limits<std::int64_t>::max());
    } else if (arg == "--walk") {
      o.walk_source = detail::parseInteger(arg, value(), 0, std::numeric_limits<std::int64_t>::max());
    } else if (arg == "--focus") {
      o.focus = true;
    } else if (arg == "--graph") {
      o.show_graph = true;
    } else if (arg == "--graph-limit") {
      o.graph_limit = static_cast<std::size_t>(detail::parseInteger(arg, value(), 0, 1LL << 40));
    } else if (arg == "--max-lines") {
      o.max_lines = static_cast<std::size_t>(detail::parseInteger(arg, value(), 1, 1LL << 40));
    } else if (arg == "--no-correspondences") {
      o.show_correspondences = false;
    } else if (arg == "--walk-scale") {
      o.walk_scale = static_cast<int>(detail::parseInteger(arg, value(), 1, 1000));
    } else if (arg == "--point-size") {
      o.point_size = detail::parseNumber(arg, value());
      if (o.point_size < 1 || o.point_size > 64)
        throw dw::Error("dw_viewer: --point-size must be in [1, 64]");
    } else if (arg == "--keys") {
      const std::string text = value();
      for (const auto& key : detail::splitList(text, ',')) {
        if (key != "n" && key != "space" && key != "z" && key != "m" && key != "t" && key != "k")
          throw dw::Error("dw_viewer: --keys knows n, space, z, m, t and k, got '" + key + "'");
        o.keys.push_back(key);
      }
    } else if (arg.size() > 1 && arg[0] == '-') {
      throw dw::Error("dw_viewer: unknown option '" + arg + "'");
    } else {
      positional.push_back(arg);
    }
  }
  if (o.help) return o;
  const bool run_mode = !o.map.empty() || !o.scan.empty() || !o.poses.empty() || !o.truth.empty();
  if (run_mode) {
    o.mode = Mode::Localization;
    if (mesh_mode || !positional.empty())
      throw dw::Error("dw_viewer: --map/--scan/--poses show a localization run and take no other files");
    if (o.map.empty() || o.scan.empty() || o.poses.empty())
      throw dw::Error(
          "dw_viewer: a localization run needs --map, --scan and --poses (and optionally --truth)");
    if (!o.keys.empty() || o.iterations >= 0 || o.pick_target >= 0 || o.walk_source >= 0)
      throw dw::Error(
          "dw_viewer: --keys, --iterations, --pick and --walk drive ICP and do not apply to --map");
    if (o.frame < 0) o.frame = detail::frameOfFileName(o.scan);
    return o;
  }
  if (mesh_mode) {
    o.mode = Mode::Tin;
    if (!positional.empty()) throw dw::Error("dw_viewer: --tin takes one file and no SOURCE/TARGET");
    if (!o.keys.empty()) throw dw::Error("dw_viewer: --keys drives ICP and does not apply to --tin");
  } else {
    if (positional.size() != 2)
      throw dw::Error("dw_viewer: expected SOURCE and TARGET clouds (or --tin FILE), got " +
                      std::to_string(positional.size()) + " file argument(s)");
    o.source = positional[0];
    o.target = positional[1];
  }
  if (o.focus && o.pick_target < 0 && o.walk_source < 0)
    throw dw::Error("dw_viewer: --focus needs --pick or --walk (what to aim at)");
  if (!o.keys.empty() && o.screenshot.empty())
    throw dw::Error("dw_viewer: --keys applies to --screenshot only");
  if (o.iterations >= 0 && o.screenshot.empty())
    throw dw::Error("dw_viewer: --iterations applies to --screenshot only (interactively, press n)");
  return o;
}

}  // namespace dw_viewer
