#include "pcl_delaunay_walk/core/registration/localizer.h"

#include <cmath>
#include <cstdio>

#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/core/registration/map_normals.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {

namespace {

/// Caller coordinates of a graph's inputs rebuilt from its vertices (origin + local, rounded to
/// float); NaN for the inputs it skipped.
std::vector<float> inputsOfGraph(const DelaunayGraph& g) {
  std::vector<float> xyz(3 * g.numInputPoints(), std::numeric_limits<float>::quiet_NaN());
  for (std::size_t i = 0; i < g.numInputPoints(); ++i) {
    const index_t v = g.input_to_vertex[i];
    if (v == kInvalidIndex) continue;
    const Vec3f& p = g.points[v];
    xyz[3 * i] = static_cast<float>(g.origin[0] + p.x);
    xyz[3 * i + 1] = static_cast<float>(g.origin[1] + p.y);
    xyz[3 * i + 2] = static_cast<float>(g.origin[2] + p.z);
  }
  return xyz;
}

}  // namespace

Localizer::Localizer(const PointView& map, const LocalizerOptions& options, const ProgressCallback& progress)
    : options_(options) {
  std::vector<float> xyz(3 * map.size);
  for (std::size_t i = 0; i < map.size; ++i) {
    const auto p = map[i];
    for (int c = 0; c < 3; ++c) xyz[3 * i + std::size_t(c)] = static_cast<float>(p[c]);
  }
  BuildOptions build;
  build.num_threads = options.num_threads;
  build.progress = progress;
  // The graph is built from the float coordinates the search answers in, so the two agree exactly.
  auto graph = std::make_shared<const DelaunayGraph>(
      buildDelaunayGraph(PointView::fromFloat(xyz.data(), map.size), build));
  init(std::move(graph), std::move(xyz));
}

Localizer::Localizer(DelaunayGraph graph, const LocalizerOptions& options) : options_(options) {
  std::vector<float> xyz = inputsOfGraph(graph);
  init(std::make_shared<const DelaunayGraph>(std::move(graph)), std::move(xyz));
}

Localizer Localizer::load(const std::string& path, const LocalizerOptions& options) {
  try {
    return Localizer(loadGraph(path), options);
  } catch (const GraphFileError& e) {
    throw GraphFileError("map graph '" + path + "' refused: " + e.what());
  }
}

void Localizer::init(std::shared_ptr<const DelaunayGraph> graph, std::vector<float> xyz) {
  auto search = std::make_shared<const CallerMetricSearch>(std::move(graph), std::move(xyz),
                                                           std::vector<std::int32_t>{});
  search_ = std::make_shared<WalkCorrespondenceSearch>(std::move(search), StartStrategy::PnnOptimized);
  setOptions(options_);
}

void Localizer::save(const std::string& path) const {
  const std::string tmp = path + ".tmp";
  try {
    saveGraph(graph(), tmp);
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw Error("cannot write map graph '" + path + "' (rename failed)");
  }
}

void Localizer::setOptions(const LocalizerOptions& options) {
  if (!(options.min_fitness >= 0 && options.min_fitness <= 1))
    throw Error("dw::Localizer: min_fitness must be in [0, 1]");
  if (!(options.voxel >= 0)) throw Error("dw::Localizer: voxel must be >= 0");
  options_ = options;
  options_.icp.num_threads = options.num_threads;
  // A start farther than a few correspondence distances walks farther than a KD-ANN descent costs.
  search_->setMaxHintDistance(4.0 * options_.icp.max_correspondence_distance);
  if (options_.icp.metric == IcpMetric::PointToPlane) mapNormals();
}

const std::vector<float>& Localizer::mapNormals() {
  if (normals_.empty() && mapPoints() > 0)
    normals_ = computeMapNormals(search_->callerSearch(), options_.normal_neighbours, options_.num_threads);
  return normals_;
}

FrameResult Localizer::registerScan(const PointView& scan) {
  const FrameRules rules{options_.voxel, options_.constant_velocity, options_.min_fitness, options_.max_rmse};
  return track_.registerFrame(scan, rules, [&](const std::vector<float>& pts, const Eigen::Matrix4d& guess) {
    if (!options_.warm_start_across_frames) workspace_.hints.assign(workspace_.hints.size(), kInvalidIndex);
    const float* normals = options_.icp.metric == IcpMetric::PointToPlane ? mapNormals().data() : nullptr;
    return alignIcp(*search_, normals, pts.data(), pts.size() / 3, guess, options_.icp, workspace_);
  });
}

}  // namespace dw
