/// \file dw_viewer.cpp
/// \brief dw_viewer: watch ICP with the Delaunay walk converge on your own clouds (source points
/// coloured by their walk length, correspondences, RMS error, NN time), inspect the target's
/// Delaunay graph, and view TINs from dw_tin coloured by height. --screenshot renders without
/// interaction (works under xvfb-run) for documentation and tests. With --map/--scan/--poses it shows
/// a localization or odometry run: the map, the scan at its estimated pose coloured by its distance
/// to the map, and the estimated trajectory beside the true one.

// GCC 12 reports -Warray-bounds false positives inside Eigen's umeyama (16-byte SSE loads of a
// Vector3f) when it inlines PCL's TransformationEstimationSVD; GCC judges the diagnostic by the state
// at the system header's location, so this must precede every include.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif

#include <pcl/common/transforms.h>
#include <pcl/visualization/pcl_visualizer.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"
#include "viewer/cloud_input.h"
#include "viewer/colour_map.h"
#include "viewer/icp_stepper.h"
#include "viewer/localization_data.h"
#include "viewer/overlay_layer.h"
#include "viewer/scene_geometry.h"
#include "viewer/viewer_options.h"
#include "viewer/walk_path.h"

namespace {

using dw_viewer::Rgb;
using Visualizer = pcl::visualization::PCLVisualizer;

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

std::string format(const char* fmt, ...) {
  char buf[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof(buf), fmt, args);
  va_end(args);
  return buf;
}

/// Counts with a k/M suffix: graph sizes span 10^2..10^7.
std::string humanCount(double n) {
  if (n >= 1e6) return format("%.2fM", n / 1e6);
  if (n >= 1e4) return format("%.0fk", n / 1e3);
  return format("%.0f", n);
}

/// The PCL visualiser set up for both modes: fixed size, no FPS counter (it would make screenshots
/// differ run to run), dark background. The interactor is kept even for screenshots: PCLVisualizer
/// renders through it.
std::unique_ptr<Visualizer> makeVisualizer(const dw_viewer::ViewerOptions& o, const std::string& title) {
  auto viewer = std::make_unique<Visualizer>(title, true);
  viewer->setSize(o.width, o.height);
  viewer->setShowFPS(false);
  viewer->setBackgroundColor(0.07, 0.08, 0.10);
  return viewer;
}

/// A translucent dark box behind a text overlay, so it stays readable over bright clouds.
void shadeText(Visualizer& viewer, const std::string& id) {
  auto shapes = viewer.getShapeActorMap();
  auto it = shapes->find(id);
  if (it == shapes->end()) return;
  if (auto* text = vtkTextActor::SafeDownCast(it->second)) {
    text->GetTextProperty()->SetBackgroundColor(0.0, 0.0, 0.0);
    text->GetTextProperty()->SetBackgroundOpacity(0.55);
  }
}

/// Camera looking at the bounding box of `xyz` from direction `dir` (unit, towards the camera), at
/// the distance where the bounding sphere fills VTK's default 30-degree view.
void fitCamera(Visualizer& viewer, const std::vector<float>& xyz, const Eigen::Vector3d& dir,
               const Eigen::Vector3d& up, double margin = 1.0) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(HUGE_VAL), hi = -lo;
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min<double>(lo[k], xyz[i + k]);
      hi[k] = std::max<double>(hi[k], xyz[i + k]);
    }
  if (xyz.empty()) lo = hi = Eigen::Vector3d::Zero();
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double radius = margin * std::max(0.5 * (hi - lo).norm(), 1e-6);
  const Eigen::Vector3d eye = centre + dir.normalized() * (radius / std::sin(M_PI / 12.0));
  viewer.setCameraPosition(eye.x(), eye.y(), eye.z(), centre.x(), centre.y(), centre.z(), up.x(), up.y(),
                           up.z());
  auto* renderer = viewer.getRendererCollection()->GetFirstRenderer();
  if (renderer) renderer->ResetCameraClippingRange();
}

/// Renders a few frames (VTK needs more than one before the buffer holds the final picture) and
/// writes the PNG to a temporary that replaces `path` only once written (saveScreenshot does not report
/// failure, so an empty temporary counts as one and an existing `path` stays as it was).
void writeScreenshot(Visualizer& viewer, const std::string& path) {
  for (int k = 0; k < 4; ++k) viewer.spinOnce(10, true);
  const std::string tmp = dw::temporaryPathFor(path);
  try {
    viewer.saveScreenshot(tmp);
    dw::commitTemporary(tmp, path);
  } catch (const std::exception& e) {
    dw::discardTemporary(tmp);
    throw dw::Error(std::string("dw_viewer: could not write the screenshot: ") + e.what());
  }
  std::cout << "screenshot written: " << path << "\n";
}

/// Rigid motion of --perturb: translation, then roll/pitch/yaw (degrees) about x, y, z.
Eigen::Matrix4f perturbation(const std::array<double, 6>& p) {
  const double d2r = M_PI / 180.0;
  Eigen::Affine3d a = Eigen::Translation3d(p[0], p[1], p[2]) *
                      Eigen::AngleAxisd(p[5] * d2r, Eigen::Vector3d::UnitZ()) *
                      Eigen::AngleAxisd(p[4] * d2r, Eigen::Vector3d::UnitY()) *
                      Eigen::AngleAxisd(p[3] * d2r, Eigen::Vector3d::UnitX());
  return a.matrix().cast<float>();
}

// ------------------------------------------------------------------------------------------------
// ICP mode

class IcpScene {
  using RgbHandler = pcl::visualization::PointCloudColorHandlerRGBField<pcl::PointXYZRGB>;

 public:
  IcpScene(const dw_viewer::ViewerOptions& o, dw_viewer::IcpStepper& icp, Visualizer& viewer,
           const std::array<double, 3>& origin)
      : o_(o),
        icp_(icp),
        viewer_(viewer),
        overlay_(viewer.getRenderWindow(), viewer.getRendererCollection()->GetFirstRenderer()),
        origin_(origin),
        show_lines_(o.show_correspondences),
        font_(std::max(10, o.height / 56)) {
    const auto& target = icp_.target();
    viewer_.addPointCloud<pcl::PointXYZ>(icp_.targetPtr(), "target");
    viewer_.setPointCloudRenderingProperties(pcl::visualization::PCL_VISUALIZER_COLOR, 0.72, 0.74, 0.78,
                                             "target");
    viewer_.setPointCloudRenderingProperties(pcl::visualization::PCL_VISUALIZER_POINT_SIZE, o_.point_size,
                                             "target");
    coloured_.reset(new pcl::PointCloud<pcl::PointXYZRGB>);
    fillSourceColours();
    showSource();
    for (int line = 0; line < 5; ++line) {
      viewer_.addText("", 10, textRowY(line), font_, 0.92, 0.92, 0.92, textId(line));
      shadeText(viewer_, textId(line));
    }
    addLegend();
    if (o_.pick_target >= 0) {
      if (static_cast<std::size_t>(o_.pick_target) >= target.size())
        throw dw::Error(format("dw_viewer: --pick %lld is not a target point (the target has %zu)",
                               static_cast<long long>(o_.pick_target), target.size()));
      pickTargetVertex(icp_.graph().input_to_vertex[static_cast<std::size_t>(o_.pick_target)]);
    }
    if (o_.walk_source >= 0) {
      if (static_cast<std::size_t>(o_.walk_source) >= icp_.source().size())
        throw dw::Error(format("dw_viewer: --walk %lld is not a source point (the source has %zu)",
                               static_cast<long long>(o_.walk_source), icp_.source().size()));
      walk_source_ = o_.walk_source;
    }
    if (o_.show_graph) toggleGraph();
    refresh();
  }

  /// (Re)adds the coloured source cloud. Not PCLVisualizer::updatePointCloud: in PCL 1.13 it
  /// reinterpret_casts the actor's vtkDataSetMapper to vtkPolyDataMapper and calls members through it,
  /// undefined behaviour that UBSan reports (docs/robustness.md, B9). Re-adding costs one conversion,
  /// the same as the update.
  void showSource() {
    viewer_.removePointCloud("source");
    viewer_.addPointCloud<pcl::PointXYZRGB>(coloured_, RgbHandler(coloured_), "source");
    viewer_.setPointCloudRenderingProperties(pcl::visualization::PCL_VISUALIZER_POINT_SIZE, o_.point_size + 1,
                                             "source");
  }

  /// Redraws everything that changes with the pose.
  void refresh() {
    fillSourceColours();
    showSource();
    replaceShape("correspondences",
                 show_lines_ ? dw_viewer::correspondenceSegments(icp_.source(), icp_.target(),
                                                                 icp_.correspondences(), o_.max_lines)
                             : dw_viewer::Segments(),
                 {0.95, 0.85, 0.35}, 1.0, 0.55);
    drawWalk();
    updateText();
  }

  void onKey(const pcl::visualization::KeyboardEvent& e) {
    if (!e.keyDown()) return;
    const std::string key = e.getKeySym();
    if (key == "n") {
      playing_ = false;
      stepAndReport();
    } else if (key == "space") {
      playing_ = !playing_ && !icp_.finished();
    } else if (key == "z") {
      playing_ = false;
      icp_.reset();
      std::cout << "ICP reset to the initial pose\n";
      refresh();
    } else if (key == "m") {
      show_lines_ = !show_lines_;
      refresh();
    } else if (key == "t") {
      toggleGraph();
    } else if (key == "k") {
      walk_source_ = -1;
      replaceShape("pick_edges", {}, {}, 0, 0);
      replacePoints("pick_points", {}, {});
      pick_xyz_.clear();
      refresh();
    }
  }

  void onPick(const pcl::visualization::PointPickingEvent& e) {
    const int idx = e.getPointIndex();
    if (idx < 0) return;
    const std::string name = e.getCloudName();
    if (name == "source" && static_cast<std::size_t>(idx) < icp_.source().size()) {
      walk_source_ = idx;
      std::cout << "source point " << idx << ": walk of " << icp_.walkLengths()[idx] << " moves\n";
      refresh();
      return;
    }
    // Anything else (target, an overlay): the target vertex nearest to the picked position, found
    // by the walk itself.
    float x, y, z;
    e.getPoint(x, y, z);
    const float q[3] = {x, y, z};
    dw::WalkNeighbour nn;
    dw::CallerMetricSearchStats qs;
    if (!icp_.targetSearch().getCallerMetricSearch()->nearest(q, dw::StartStrategy::KdAnn, dw::kInvalidIndex,
                                                              nn, &qs))
      return;
    pickTargetVertex(qs.nn_vertex);
    std::cout << "target point " << nn.index << ": vertex " << qs.nn_vertex << " with "
              << icp_.graph().degree(qs.nn_vertex) << " Delaunay neighbours\n";
  }

  /// Points of the pick and walk overlays (what --focus aims at).
  std::vector<float> focusPoints() const {
    std::vector<float> xyz = pick_xyz_;
    xyz.insert(xyz.end(), walk_xyz_.begin(), walk_xyz_.end());
    return xyz;
  }

  bool playing() const { return playing_; }

  void stepAndReport() {
    if (!icp_.step()) {
      playing_ = false;
      std::cout << "ICP " << dw_viewer::IcpStepper::stateName(icp_.state()) << " after " << icp_.iteration()
                << " iterations\n";
      updateText();
      return;
    }
    const auto& s = icp_.stats();
    std::cout << format("iteration %d: RMS %.6g, NN %.2f ms, mean walk %.2f moves, %zu correspondences\n",
                        icp_.iteration(), s.rms, 1e3 * s.nn_seconds, s.meanWalk(), s.correspondences);
    if (icp_.finished()) playing_ = false;
    refresh();
  }

 private:
  static std::string textId(int line) { return "info" + std::to_string(line); }

  /// The strategy as the walks of this search really started (PNN has no hint in the first one).
  std::string startLabel() const {
    const dw::StartStrategy s = icp_.startStrategy();
    if (icp_.iteration() == 0 && s == dw::StartStrategy::PnnOptimized) return "kd-ann (first search)";
    if (icp_.iteration() == 0 && s == dw::StartStrategy::Pnn) return "zero (first search)";
    return dw::toString(s);
  }

  /// Text rows are placed from the top, so they follow the window when it is resized.
  int textRowY(int row) const {
    const int* size = viewer_.getRenderWindow()->GetSize();
    const int height = size && size[1] > 0 ? size[1] : o_.height;
    return height - (row + 1) * (font_ + 6) - 4;
  }

  void fillSourceColours() {
    const auto& src = icp_.source();
    const auto& walks = icp_.walkLengths();
    coloured_->resize(src.size());
    for (std::size_t i = 0; i < src.size(); ++i) {
      auto& p = (*coloured_)[i];
      p.x = src[i].x;
      p.y = src[i].y;
      p.z = src[i].z;
      const Rgb c = dw_viewer::walkColour(i < walks.size() ? walks[i] : 0, o_.walk_scale);
      p.r = c[0];
      p.g = c[1];
      p.b = c[2];
    }
    coloured_->width = static_cast<std::uint32_t>(coloured_->size());
    coloured_->height = 1;
  }

  void addLegend() {
    const int y = 10;
    int x = 10;
    viewer_.addText("walk moves:", x, y, font_, 0.92, 0.92, 0.92, "legend_title");
    x += static_cast<int>(font_ * 7.2);
    for (int s = 0; s <= o_.walk_scale; ++s) {
      const Rgb c = dw_viewer::walkColour(static_cast<std::uint32_t>(s), o_.walk_scale);
      const std::string label = s == o_.walk_scale ? std::to_string(s) + "+" : std::to_string(s);
      viewer_.addText(label, x, y, font_, c[0] / 255.0, c[1] / 255.0, c[2] / 255.0,
                      "legend" + std::to_string(s));
      x += static_cast<int>(font_ * (0.8 + 0.65 * label.size()));
    }
    viewer_.addText("target", x + font_, y, font_, 0.72, 0.74, 0.78, "legend_target");
  }

  void updateText() {
    const auto& s = icp_.stats();
    const auto& g = icp_.graph();
    std::string lines[5];
    lines[0] = format("ICP with the Delaunay walk   iteration %d / %d   %s", icp_.iteration(),
                      o_.max_iterations, dw_viewer::IcpStepper::stateName(icp_.state()));
    lines[1] =
        format("RMS error %.6g   correspondences %zu of %zu", s.rms, s.correspondences, icp_.source().size());
    lines[2] = format("NN time %.2f ms (%.3f us/query)   mean walk %.2f moves (max %u)   start: %s",
                      1e3 * s.nn_seconds, s.queries ? 1e6 * s.nn_seconds / s.queries : 0.0, s.meanWalk(),
                      s.max_walk, startLabel().c_str());
    lines[3] = format("target graph: %s vertices, %s edges (%dD), built in %.2f s",
                      humanCount(g.numVertices()).c_str(), humanCount(g.numDirectedEdges() / 2.0).c_str(),
                      g.dimension, icp_.graphBuildSeconds());
    if (origin_[0] != 0 || origin_[1] != 0 || origin_[2] != 0)
      lines[3] += format("   origin (%.0f, %.0f, %.0f)", origin_[0], origin_[1], origin_[2]);
    if (o_.screenshot.empty())
      lines[4] = "n step   space play/pause   z reset   m lines   t graph   k clear   shift+click pick";
    for (int k = 0; k < 5; ++k)
      viewer_.updateText(lines[k], 10, textRowY(k), font_, 0.92, 0.92, 0.92, textId(k));
  }

  void replaceShape(const std::string& id, const dw_viewer::Segments& seg, const std::array<double, 3>& rgb,
                    double width, double opacity) {
    if (seg.empty())
      overlay_.remove(id);
    else
      overlay_.set(id, dw_viewer::makeLines(seg), rgb, width, opacity);
  }

  void replacePoints(const std::string& id, const std::vector<float>& xyz, const std::vector<Rgb>& colours,
                     double size = 1.0) {
    if (xyz.empty())
      overlay_.remove(id);
    else
      overlay_.set(id, dw_viewer::makePoints(xyz, colours), {1.0, 1.0, 1.0}, size);
  }

  /// Seed Fig. 4: the vertex, its Delaunay edges and its neighbours.
  void pickTargetVertex(dw::index_t v) {
    const auto& g = icp_.graph();
    if (v >= g.numVertices()) return;
    replaceShape("pick_edges", dw_viewer::vertexEdgeSegments(g, icp_.target(), v), {0.2, 0.95, 0.95}, 2.5,
                 1.0);
    std::vector<float> xyz;
    std::vector<Rgb> colours;
    const auto& a = dw_viewer::vertexPoint(g, icp_.target(), v);
    xyz.insert(xyz.end(), {a.x, a.y, a.z});
    colours.push_back({{255, 40, 200}});
    for (dw::index_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k) {
      const auto& b = dw_viewer::vertexPoint(g, icp_.target(), g.edges[k].j);
      xyz.insert(xyz.end(), {b.x, b.y, b.z});
      colours.push_back({{60, 255, 255}});
    }
    replacePoints("pick_points", xyz, colours, o_.point_size + 6);
    pick_xyz_ = xyz;
  }

  /// The walk of the selected source point in the current search: start vertex to nearest vertex.
  void drawWalk() {
    if (walk_source_ < 0) {
      replaceShape("walk_path", {}, {}, 0, 0);
      replacePoints("walk_points", {}, {});
      walk_xyz_.clear();
      return;
    }
    const auto& g = icp_.graph();
    const auto& p = icp_.source()[static_cast<std::size_t>(walk_source_)];
    const dw::Vec3f ql = g.toLocal(p.x, p.y, p.z);
    const dw::index_t hint = icp_.hintsUsed()[static_cast<std::size_t>(walk_source_)];
    const dw::index_t start = icp_.targetSearch().getCallerMetricSearch()->neighbourSearch().startVertex(
        ql, icp_.startStrategy(), hint);
    const auto path = dw_viewer::walkPath(g, ql, start);
    dw_viewer::Segments seg = dw_viewer::pathSegments(g, icp_.target(), path);
    const auto& end = dw_viewer::vertexPoint(g, icp_.target(), path.back());
    seg.insert(seg.end(), {p.x, p.y, p.z, end.x, end.y, end.z});  // query to its nearest neighbour
    replaceShape("walk_path", seg, {1.0, 0.45, 0.1}, 3.0, 1.0);
    std::vector<float> xyz{p.x, p.y, p.z};
    std::vector<Rgb> colours{{{255, 255, 255}}};
    for (std::size_t k = 0; k < path.size(); ++k) {
      const auto& b = dw_viewer::vertexPoint(g, icp_.target(), path[k]);
      xyz.insert(xyz.end(), {b.x, b.y, b.z});
      colours.push_back(k == 0                 ? Rgb{{255, 230, 0}}
                        : k + 1 == path.size() ? Rgb{{255, 40, 40}}
                                               : Rgb{{255, 140, 30}});
    }
    replacePoints("walk_points", xyz, colours, o_.point_size + 6);
    walk_xyz_ = xyz;
  }

  void toggleGraph() {
    if (graph_shown_) {
      replaceShape("graph", {}, {}, 0, 0);
      graph_shown_ = false;
      return;
    }
    const auto& g = icp_.graph();
    const std::size_t edges = g.numDirectedEdges() / 2;
    if (edges > o_.graph_limit) {
      std::cout << "the target graph has " << edges << " edges, more than --graph-limit " << o_.graph_limit
                << ": not drawn (pick points instead)\n";
      return;
    }
    replaceShape("graph", dw_viewer::graphSegments(g, icp_.target()), {0.45, 0.55, 0.85}, 1.0, 0.35);
    graph_shown_ = true;
  }

 private:
  const dw_viewer::ViewerOptions& o_;
  dw_viewer::IcpStepper& icp_;
  Visualizer& viewer_;
  dw_viewer::OverlayLayer overlay_;
  std::array<double, 3> origin_;
  pcl::PointCloud<pcl::PointXYZRGB>::Ptr coloured_;
  bool show_lines_;
  bool graph_shown_ = false;
  bool playing_ = false;
  int font_;
  std::int64_t walk_source_ = -1;
  std::vector<float> pick_xyz_, walk_xyz_;
};

int runIcp(const dw_viewer::ViewerOptions& o) {
  const dw_viewer::XyzPoints target_pts = dw_viewer::loadXyz(o.target, o.las_class);
  const dw_viewer::XyzPoints source_pts = dw_viewer::loadXyz(o.source, o.las_class);
  // One origin for both clouds (the target's), so ICP runs in one frame near zero.
  const auto origin = dw_viewer::chooseOrigin(target_pts.xyz);
  auto target = dw_viewer::toCloud(target_pts, origin);
  auto source = dw_viewer::toCloud(source_pts, origin);
  const auto& pt = o.perturb;
  if (pt[0] != 0 || pt[1] != 0 || pt[2] != 0 || pt[3] != 0 || pt[4] != 0 || pt[5] != 0)
    pcl::transformPointCloud(*source, *source, perturbation(pt));
  std::cout << "target " << o.target << ": " << target->size() << " points (" << target_pts.skipped
            << " non-finite skipped)\nsource " << o.source << ": " << source->size() << " points ("
            << source_pts.skipped << " non-finite skipped)\n";

  dw_viewer::IcpSettings s;
  s.max_iterations = o.max_iterations;
  s.max_correspondence_distance = o.max_correspondence_distance;
  s.transformation_epsilon = o.transformation_epsilon;
  s.euclidean_fitness_epsilon = o.euclidean_fitness_epsilon;
  s.start = o.start;
  s.threads = o.threads;
  s.build.builder = o.builder;
  s.build.num_threads = o.threads;
  dw_viewer::IcpStepper icp(source, target, s);
  const double build_seconds = icp.graphBuildSeconds();
  std::cout << format("target graph: %zu vertices, %zu edges, built in %.3f s\n", icp.graph().numVertices(),
                      icp.graph().numDirectedEdges() / 2, build_seconds);

  if (!o.screenshot.empty()) {
    // Without --iterations: run to the end, unless scripted keys are to drive ICP from the start.
    const int n = o.iterations >= 0 ? o.iterations : o.keys.empty() ? o.max_iterations : 0;
    for (int k = 0; k < n && icp.step(); ++k) {
    }
  }
  auto viewer = makeVisualizer(o, "dw_viewer: ICP with the Delaunay walk");
  IcpScene scene(o, icp, *viewer, origin);
  // Bunny-style scans look along -z; a slightly raised front view shows depth as well.
  std::vector<float> xyz;
  xyz.reserve(3 * (target->size() + source->size()));
  for (const auto* c : {&icp.target(), &icp.source()})
    for (const auto& p : *c) xyz.insert(xyz.end(), {p.x, p.y, p.z});
  if (o.focus)  // the overlay and its surroundings: Delaunay edges are ~point spacing long
    fitCamera(*viewer, scene.focusPoints(), Eigen::Vector3d(0.25, 0.2, 1.0), Eigen::Vector3d::UnitY(), 1.4);
  else
    fitCamera(*viewer, xyz, Eigen::Vector3d(0.25, 0.2, 1.0), Eigen::Vector3d::UnitY());

  if (!o.screenshot.empty()) {
    for (const auto& key : o.keys) {
      std::cout << "key " << key << "\n";
      scene.onKey(pcl::visualization::KeyboardEvent(true, key, 0, false, false, false));
      while (scene.playing()) scene.stepAndReport();  // space: play to the end, as the window would
    }
    std::cout << format("ICP %s after %d iterations; RMS %.6g\n",
                        dw_viewer::IcpStepper::stateName(icp.state()), icp.iteration(), icp.stats().rms);
    writeScreenshot(*viewer, o.screenshot);
    return 0;
  }
  viewer->registerKeyboardCallback([&](const pcl::visualization::KeyboardEvent& e) { scene.onKey(e); });
  viewer->registerPointPickingCallback(
      [&](const pcl::visualization::PointPickingEvent& e) { scene.onPick(e); });
  std::cout << dw_viewer::usageText();
  while (!viewer->wasStopped()) {
    viewer->spinOnce(scene.playing() ? 1 : 30);
    if (scene.playing()) scene.stepAndReport();
  }
  return 0;
}

// ------------------------------------------------------------------------------------------------
// TIN mode

int runTin(const dw_viewer::ViewerOptions& o) {
  dw_viewer::TriangleMesh mesh = dw_viewer::loadMesh(o.tin, o.las_class);
  std::string how = "mesh from file";
  if (mesh.numTriangles() == 0) {
    // A cloud: triangulate it here with the project's parallel TIN builder.
    const std::size_t n = mesh.numVertices();
    std::vector<double> x(n), y(n);
    for (std::size_t i = 0; i < n; ++i) {
      x[i] = mesh.xyz[3 * i];
      y[i] = mesh.xyz[3 * i + 1];
    }
    const auto origin = dw_viewer::chooseOrigin(mesh.xyz);
    for (std::size_t i = 0; i < n; ++i) {  // centred, as dw::tin::triangulate asks
      x[i] -= origin[0];
      y[i] -= origin[1];
    }
    dw::tin::TinOptions topt;
    topt.num_threads = o.threads;
    const auto t0 = std::chrono::steady_clock::now();
    const dw::tin::TinResult r = dw::tin::triangulate(std::move(x), std::move(y), topt);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (r.numTriangles() == 0)
      throw dw::Error("dw_viewer: " + o.tin + ": the points are collinear, no TIN exists");
    mesh.triangles.assign(r.triangles.begin(), r.triangles.end());
    how = format("triangulated here in %.2f s", secs);
  }
  const auto origin = dw_viewer::chooseOrigin(mesh.xyz);
  const std::size_t n = mesh.numVertices();
  std::vector<float> xyz(3 * n);
  std::vector<double> heights(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) xyz[3 * i + k] = static_cast<float>(mesh.xyz[3 * i + k] - origin[k]);
    heights[i] = mesh.xyz[3 * i + 2];
  }
  const auto range = dw_viewer::quantileRange(heights);
  std::vector<Rgb> colours(n);
  for (std::size_t i = 0; i < n; ++i)
    colours[i] = dw_viewer::heightColour((heights[i] - range[0]) / (range[1] - range[0]));
  std::cout << o.tin << ": " << n << " vertices, " << mesh.numTriangles() << " triangles (" << how << ")\n";

  auto viewer = makeVisualizer(o, "dw_viewer: TIN");
  viewer->addModelFromPolyData(dw_viewer::makeColouredMesh(xyz, mesh.triangles, colours), "tin");
  const int font = std::max(10, o.height / 56);
  const std::string name =
      o.tin.substr(o.tin.find_last_of('/') == std::string::npos ? 0 : o.tin.find_last_of('/') + 1);
  viewer->addText(format("TIN %s: %s vertices, %s triangles, %s", name.c_str(), humanCount(n).c_str(),
                         humanCount(mesh.numTriangles()).c_str(), how.c_str()),
                  10, o.height - font - 10, font, 0.92, 0.92, 0.92, "tin_info");
  shadeText(*viewer, "tin_info");
  // Height legend, five steps of the colour ramp with their heights.
  int x = 10;
  viewer->addText("height:", x, 10, font, 0.92, 0.92, 0.92, "legend_title");
  x += font * 4;
  for (int s = 0; s <= 4; ++s) {
    const double t = s / 4.0;
    const Rgb c = dw_viewer::heightColour(t);
    const std::string label = format("%.1f", range[0] + t * (range[1] - range[0]));
    viewer->addText(label, x, 10, font, c[0] / 255.0, c[1] / 255.0, c[2] / 255.0,
                    "legend" + std::to_string(s));
    x += static_cast<int>(font * (1.0 + 0.62 * label.size()));
  }
  // Oblique view from the south-south-west: relief reads better than straight down.
  // A TIN is flat: its bounding sphere overstates what must fit, hence a tighter margin, relaxed
  // for narrower windows, where the tile's long side would otherwise be cut.
  const double aspect = static_cast<double>(o.width) / o.height;
  fitCamera(*viewer, xyz, Eigen::Vector3d(-0.25, -1.0, 1.1), Eigen::Vector3d::UnitZ(),
            0.7 * std::max(1.0, 1.6 / aspect));
  if (!o.screenshot.empty()) {
    writeScreenshot(*viewer, o.screenshot);
    return 0;
  }
  while (!viewer->wasStopped()) viewer->spinOnce(30);
  return 0;
}

// ------------------------------------------------------------------------------------------------
// Localization mode

/// Flat colours of the trajectories (overlays are unlit, so these are the pixels' exact values).
constexpr std::array<double, 3> kEstimateColour{{1.0, 40 / 255.0, 220 / 255.0}};
constexpr std::array<double, 3> kTruthColour{{40 / 255.0, 1.0, 90 / 255.0}};

int runLocalization(const dw_viewer::ViewerOptions& o) {
  const dw_viewer::XyzPoints map = dw_viewer::loadPointsAnyFormat(o.map, o.las_class);
  const dw_viewer::XyzPoints scan = dw_viewer::loadPointsAnyFormat(o.scan);
  const auto estimate = dw_viewer::loadPoses(o.poses);
  const auto truth = o.truth.empty() ? std::vector<Eigen::Isometry3d>() : dw_viewer::loadPoses(o.truth);
  const auto k = static_cast<std::size_t>(o.frame);
  if (k >= estimate.size())
    throw dw::Error(format("dw_viewer: --frame %zu is past the end of %s (%zu poses)", k, o.poses.c_str(),
                           estimate.size()));
  if (!truth.empty() && k >= truth.size())
    throw dw::Error(
        format("dw_viewer: --frame %zu is past the end of %s (%zu poses)", k, o.truth.c_str(), truth.size()));
  std::cout << "map " << o.map << ": " << map.size() << " points\nscan " << o.scan << ": " << scan.size()
            << " points, frame " << k << " of " << estimate.size() << "\n";
  const dw_viewer::ScanOnMap on_map =
      dw_viewer::scanOnMap(map, scan, estimate[k], o.distance_scale, dw::resolveThreads(o.threads));
  std::cout << format("distance to the map: median %.3f m, p95 %.3f m, %zu of %zu points at %.2f m or more\n",
                      on_map.quantile(0.5), on_map.quantile(0.95), on_map.atCap(), scan.size(),
                      o.distance_scale)
            << format("walk graph of %zu map points near the scan built in %.2f s, %zu queries in %.3f s\n",
                      on_map.crop_points, on_map.build_seconds, scan.size(), on_map.query_seconds);

  const auto origin = dw_viewer::chooseOrigin(map.xyz);
  auto viewer = makeVisualizer(o, "dw_viewer: localization");
  dw_viewer::OverlayLayer overlay(viewer->getRenderWindow(),
                                  viewer->getRendererCollection()->GetFirstRenderer());
  // The map, every n-th point: uniform thinning of a cloud in its file order.
  const std::size_t stride = std::max<std::size_t>(1, (map.size() + o.map_shown - 1) / o.map_shown);
  pcl::PointCloud<pcl::PointXYZ>::Ptr shown(new pcl::PointCloud<pcl::PointXYZ>);
  for (std::size_t i = 0; i < map.size(); i += stride)
    shown->push_back(pcl::PointXYZ(static_cast<float>(map.xyz[3 * i] - origin[0]),
                                   static_cast<float>(map.xyz[3 * i + 1] - origin[1]),
                                   static_cast<float>(map.xyz[3 * i + 2] - origin[2])));
  viewer->addPointCloud<pcl::PointXYZ>(shown, "map");
  viewer->setPointCloudRenderingProperties(pcl::visualization::PCL_VISUALIZER_COLOR, 0.55, 0.57, 0.60, "map");
  viewer->setPointCloudRenderingProperties(pcl::visualization::PCL_VISUALIZER_POINT_SIZE, 1.0, "map");
  pcl::PointCloud<pcl::PointXYZRGB>::Ptr coloured(new pcl::PointCloud<pcl::PointXYZRGB>);
  std::vector<float> near_xyz;  // what the camera frames: the scan near the sensor, the trajectories
  const Eigen::Vector3d sensor = estimate[k].translation();
  for (std::size_t i = 0; i < scan.size(); ++i) {
    pcl::PointXYZRGB p;
    p.x = static_cast<float>(on_map.xyz[3 * i] - origin[0]);
    p.y = static_cast<float>(on_map.xyz[3 * i + 1] - origin[1]);
    p.z = static_cast<float>(on_map.xyz[3 * i + 2] - origin[2]);
    const Rgb c = dw_viewer::distanceColour(on_map.distance[i] / o.distance_scale);
    p.r = c[0];
    p.g = c[1];
    p.b = c[2];
    coloured->push_back(p);
    if ((Eigen::Vector3d(on_map.xyz[3 * i], on_map.xyz[3 * i + 1], on_map.xyz[3 * i + 2]) - sensor).norm() <
        40.0)
      near_xyz.insert(near_xyz.end(), {p.x, p.y, p.z});
  }
  viewer->addPointCloud<pcl::PointXYZRGB>(
      coloured, pcl::visualization::PointCloudColorHandlerRGBField<pcl::PointXYZRGB>(coloured), "scan");
  viewer->setPointCloudRenderingProperties(pcl::visualization::PCL_VISUALIZER_POINT_SIZE, o.point_size,
                                           "scan");
  const auto est_seg = dw_viewer::trajectorySegments(estimate, origin);
  const auto true_seg = dw_viewer::trajectorySegments(truth, origin);
  // The truth wider and beneath: where the two coincide, it still shows on both sides.
  if (!true_seg.empty()) overlay.set("truth", dw_viewer::makeLines(true_seg), kTruthColour, 6.0);
  if (!est_seg.empty()) overlay.set("estimate", dw_viewer::makeLines(est_seg), kEstimateColour, 3.0);
  std::vector<float> marker{static_cast<float>(sensor.x() - origin[0]),
                            static_cast<float>(sensor.y() - origin[1]),
                            static_cast<float>(sensor.z() - origin[2])};
  overlay.set("current", dw_viewer::makePoints(marker), {1.0, 1.0, 1.0}, o.point_size + 8);
  for (const auto* seg : {&est_seg, &true_seg}) near_xyz.insert(near_xyz.end(), seg->begin(), seg->end());
  near_xyz.insert(near_xyz.end(), marker.begin(), marker.end());

  // Text: the frame, the pose error, the distances; the colour scale at the bottom.
  const int font = std::max(10, o.height / 56);
  std::vector<std::string> lines;
  lines.push_back(format("frame %zu of %zu   scan: %s points   map: %s points (%s shown)", k, estimate.size(),
                         humanCount(scan.size()).c_str(), humanCount(map.size()).c_str(),
                         humanCount(shown->size()).c_str()));
  if (truth.empty()) {
    lines.push_back("estimated trajectory (magenta); no --truth given");
  } else {
    const auto err = dw_viewer::poseError(estimate[k], truth[k]);
    lines.push_back(
        format("estimate (magenta) vs truth (green): %.3f m, %.3f deg at this frame", err[0], err[1]));
  }
  lines.push_back(format(
      "distance to the map (Delaunay walk): median %.3f m, p95 %.3f m, %.1f%% at %.2f m or more",
      on_map.quantile(0.5), on_map.quantile(0.95), 100.0 * on_map.atCap() / scan.size(), o.distance_scale));
  for (std::size_t r = 0; r < lines.size(); ++r) {
    const std::string id = "info" + std::to_string(r);
    viewer->addText(lines[r], 10, o.height - static_cast<int>(r + 1) * (font + 6) - 4, font, 0.92, 0.92, 0.92,
                    id);
    shadeText(*viewer, id);
  }
  int x = 10;
  viewer->addText("distance to map (m):", x, 10, font, 0.92, 0.92, 0.92, "legend_title");
  x += static_cast<int>(font * 11.5);
  for (int s = 0; s <= 4; ++s) {
    const Rgb c = dw_viewer::distanceColour(s / 4.0);
    const std::string label = format(s == 4 ? "%.2f+" : "%.2f", o.distance_scale * s / 4.0);
    viewer->addText(label, x, 10, font, c[0] / 255.0, c[1] / 255.0, c[2] / 255.0,
                    "legend" + std::to_string(s));
    x += static_cast<int>(font * (1.0 + 0.62 * label.size()));
  }
  // From behind and above the vehicle, looking ahead: the road, the facades and the path read at once.
  const Eigen::Vector3d forward = estimate[k].linear().col(0);
  fitCamera(*viewer, near_xyz, Eigen::Vector3d(-0.9 * forward.x(), -0.9 * forward.y(), 1.0),
            Eigen::Vector3d(forward.x(), forward.y(), 0.0).normalized(), 0.8);
  if (!o.screenshot.empty()) {
    writeScreenshot(*viewer, o.screenshot);
    return 0;
  }
  while (!viewer->wasStopped()) viewer->spinOnce(30);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  dw_viewer::ViewerOptions o;
  try {
    o = dw_viewer::parseViewerOptions(argc, argv);
  } catch (const dw::Error& e) {
    std::cerr << e.what() << "\n\n" << dw_viewer::usageText();
    return 2;
  }
  if (o.help) {
    std::cout << dw_viewer::usageText();
    return 0;
  }
  try {
    // VTK aborts the process without a display; say what to do instead.
    const char* display = std::getenv("DISPLAY");
    if (!display || !*display)
      throw dw::Error(
          "dw_viewer: no X display (DISPLAY is unset). For screenshots without a screen run "
          "xvfb-run -a -s \"-screen 0 1280x1024x24\" dw_viewer ... --screenshot out.png");
    switch (o.mode) {
      case dw_viewer::Mode::Icp: return runIcp(o);
      case dw_viewer::Mode::Tin: return runTin(o);
      case dw_viewer::Mode::Localization: return runLocalization(o);
    }
    return 1;
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
}
