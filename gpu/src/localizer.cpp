// dw::gpu::Localizer: the CPU localizer's frame logic (dw::FrameTrack) around the device ICP.
#include "pcl_delaunay_walk/gpu/localizer.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_io.h"

namespace dw {
namespace gpu {

namespace {

Matrix4d toRowMajor(const Eigen::Matrix4d& m) {
  Matrix4d out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[std::size_t(4 * r + c)] = m(r, c);
  return out;
}

Eigen::Matrix4d fromRowMajor(const Matrix4d& m) {
  Eigen::Matrix4d out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out(r, c) = m[std::size_t(4 * r + c)];
  return out;
}

IcpConvergence convergenceOf(ConvergenceState s) {
  switch (s) {
    case ConvergenceState::Iterations: return IcpConvergence::Iterations;
    case ConvergenceState::Transform: return IcpConvergence::Transform;
    case ConvergenceState::AbsMse: return IcpConvergence::AbsoluteMse;
    case ConvergenceState::RelMse: return IcpConvergence::RelativeMse;
    case ConvergenceState::NoCorrespondences: return IcpConvergence::NoCorrespondences;
    case ConvergenceState::NotConverged:
    case ConvergenceState::FailureAfterMaxIterations: return IcpConvergence::NotConverged;
  }
  return IcpConvergence::NotConverged;
}

/// The map graph built from the points rounded to float, as dw::Localizer builds its own.
DelaunayGraph buildMapGraph(const PointView& map, const LocalizerOptions& options,
                            const ProgressCallback& progress) {
  std::vector<float> xyz(3 * map.size);
  for (std::size_t i = 0; i < map.size; ++i) {
    const auto p = map[i];
    for (int c = 0; c < 3; ++c) xyz[3 * i + std::size_t(c)] = static_cast<float>(p[c]);
  }
  BuildOptions build;
  build.num_threads = options.num_threads;
  build.progress = progress;
  return buildDelaunayGraph(PointView::fromFloat(xyz.data(), map.size), build);
}

}  // namespace

IcpParameters icpParametersFor(const dw::IcpOptions& o) {
  if (o.metric != IcpMetric::PointToPoint)
    throw Error("dw::gpu::Localizer: the GPU ICP is point-to-point only (dw::Localizer does point-to-plane)");
  if (o.kernel != RobustKernel::None)
    throw Error("dw::gpu::Localizer: the GPU ICP has no robust kernel (dw::Localizer has Huber and Cauchy)");
  if (o.max_iterations < 1) throw Error("dw::gpu::Localizer: max_iterations must be >= 1");
  if (!(o.max_correspondence_distance > 0))
    throw Error("dw::gpu::Localizer: max_correspondence_distance must be > 0");
  IcpParameters p;
  p.max_iterations = o.max_iterations;
  p.transformation_epsilon = o.transformation_epsilon;
  p.transformation_rotation_epsilon = o.rotation_epsilon;
  p.euclidean_fitness_epsilon = o.euclidean_fitness_epsilon;
  p.mse_threshold_absolute = o.absolute_mse_epsilon;
  // An infinite distance is "no bound" to both loops; the device compares squares, which stay inf.
  p.max_correspondence_distance = o.max_correspondence_distance;
  p.min_number_correspondences = unsigned(
      std::min<std::size_t>(std::max<std::size_t>(o.min_correspondences, 1), std::size_t(0xffffffffu)));
  p.failure_after_max_iterations = false;
  p.max_iterations_similar_transforms = 0;
  p.float_transform_criteria = false;  // dw::alignIcp tests the increment in double
  p.move_source_in_float = true;       // and moves the scan in float by each increment
  return p;
}

Localizer::Localizer(const PointView& map, const LocalizerOptions& options, const ProgressCallback& progress)
    : Localizer(buildMapGraph(map, options, progress), options) {}

Localizer::Localizer(DelaunayGraph graph, const LocalizerOptions& options)
    : graph_(std::make_shared<const DelaunayGraph>(std::move(graph))) {
  if (cudaDeviceCount() == 0)
    throw CudaError(cudaErrorNoDevice, "dw::gpu::Localizer: no CUDA device (use dw::Localizer on the CPU)");
  auto walk = std::make_shared<DelaunayWalk>();
  walk->setGraph(*graph_);  // once: the map stays resident for every frame
  map_ = walk;
  icp_ = std::make_unique<IterativeClosestPoint>(map_);
  setOptions(options);
}

Localizer Localizer::load(const std::string& path, const LocalizerOptions& options) {
  DelaunayGraph g;
  try {
    g = loadGraph(path);
  } catch (const GraphFileError& e) {
    throw GraphFileError("map graph '" + path + "' refused: " + e.what());
  }
  return Localizer(std::move(g), options);
}

void Localizer::save(const std::string& path) const {
  saveGraph(*graph_, path);
}

void Localizer::setOptions(const LocalizerOptions& options) {
  if (!(options.min_fitness >= 0 && options.min_fitness <= 1))
    throw Error("dw::gpu::Localizer: min_fitness must be in [0, 1]");
  if (!(options.voxel >= 0)) throw Error("dw::gpu::Localizer: voxel must be >= 0");
  icp_->setParameters(icpParametersFor(options.icp));
  icp_->setWarmStart(options.warm_start_across_frames);
  if (!options.warm_start_across_frames) icp_->clearWarmStart();
  options_ = options;
}

FrameResult Localizer::registerScan(const PointView& scan) {
  const FrameRules rules{options_.voxel, options_.constant_velocity, options_.min_fitness, options_.max_rmse};
  return track_.registerFrame(scan, rules, [&](const std::vector<float>& pts, const Eigen::Matrix4d& guess) {
    icp_->setInputSource(PointView::fromFloat(pts.data(), pts.size() / 3));
    const IcpResult icp = icp_->align(toRowMajor(guess));
    dw::IcpResult out;
    out.transform = fromRowMajor(icp.transformation);
    out.iterations = icp.iterations;
    out.convergence = convergenceOf(icp.state);
    out.converged = icp.converged;
    out.valid_points = pts.size() / 3;
    out.correspondences = icp.correspondences;
    out.mse = icp.mse;
    return out;  // search_seconds stays 0: the search runs inside the device loop
  });
}

}  // namespace gpu
}  // namespace dw
