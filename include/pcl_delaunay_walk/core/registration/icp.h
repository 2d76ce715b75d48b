/// \file icp.h
/// \brief The ICP loop of the localizer and the odometry: correspondences from any exact nearest-
/// neighbour search (the Delaunay walk, or a k-d tree for comparison), point-to-point (closed form,
/// Umeyama) or point-to-plane (one Gauss-Newton step of the 6x6 normal equations per iteration), an
/// optional robust kernel, and the convergence criteria of PCL's IterativeClosestPoint.
///
/// With the defaults (point-to-point, no kernel) one alignIcp() call does what
/// pcl::IterativeClosestPoint<PointXYZ, PointXYZ, double>::align does on the same inputs: the scan is
/// kept as float coordinates moved by each iteration's increment (computed in double, rounded once),
/// correspondences with squared distance <= max_correspondence_distance^2 are kept, fewer than 3 stop
/// the loop, and the transformation-epsilon / MSE tests are PCL's DefaultConvergenceCriteria. So the
/// poses agree to rounding (the tests compare them within 1e-6 relative).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {

/// What the ICP loop needs from a map: its points and the exact nearest one of a query.
class CorrespondenceSearch {
 public:
  virtual ~CorrespondenceSearch() = default;
  /// Number of map points (indices returned by nearest() are below it).
  virtual std::size_t size() const = 0;
  /// Caller coordinates of map point i (3 floats).
  virtual const float* point(std::size_t i) const = 0;
  /// Exact nearest map point of q (squared distance in the caller's float metric). `hint` is a warm
  /// start owned by the search (kInvalidIndex: none) and is replaced by one for the next query near q.
  /// Returns false for a non-finite query or an empty map. Called concurrently from several threads.
  virtual bool nearest(const float q[3], index_t& hint, std::int32_t& index, float& dist2) const = 0;
  /// Optional: start loading what a query with this hint reads first.
  virtual void prefetch(index_t /*hint*/) const {}
  /// Optional: of two warm starts for q (either may be kInvalidIndex), the one to start from. The
  /// loop offers the point's own hint (its answer in the previous iteration, or frame) and the answer
  /// of the query before it, which a scan in sensor order puts near q: at a frame's first iteration
  /// the own hint is a different return of the previous scan, often metres away.
  virtual index_t closerStart(const float* /*q*/, index_t own, index_t /*previous*/) const { return own; }
};

enum class IcpMetric { PointToPoint, PointToPlane };

/// Robust kernels as iteratively reweighted least squares weights w(r) of the residual r:
/// Huber w = min(1, k/|r|), Cauchy w = 1 / (1 + (r/k)^2), with k = IcpOptions::kernel_scale.
enum class RobustKernel { None, Huber, Cauchy };

/// Why the loop stopped (PCL's DefaultConvergenceCriteria states, same meaning).
enum class IcpConvergence {
  NotConverged,
  Iterations,         ///< max_iterations reached
  Transform,          ///< the increment was below transformation_epsilon / the rotation threshold
  AbsoluteMse,        ///< |MSE - previous MSE| < absolute_mse_epsilon
  RelativeMse,        ///< |MSE - previous MSE| / previous MSE < euclidean_fitness_epsilon
  NoCorrespondences,  ///< fewer than min_correspondences within the distance (not converged)
};
const char* toString(IcpConvergence c);

struct IcpOptions {
  IcpMetric metric = IcpMetric::PointToPoint;
  double max_correspondence_distance = std::numeric_limits<double>::infinity();
  int max_iterations = 50;
  /// PCL's transformation epsilon: converged when the increment's squared translation is <= it and
  /// the cosine of its rotation angle >= rotation_epsilon (when 0: 1 - transformation_epsilon).
  double transformation_epsilon = 1e-10;
  double rotation_epsilon = 0.0;
  /// PCL's Euclidean fitness epsilon (relative MSE change); -max disables, as in PCL.
  double euclidean_fitness_epsilon = -std::numeric_limits<double>::max();
  double absolute_mse_epsilon = 1e-12;  ///< PCL's fixed absolute MSE threshold
  RobustKernel kernel = RobustKernel::None;
  double kernel_scale = 1.0;  ///< k of the kernel, in metres
  std::size_t min_correspondences = 3;
  unsigned num_threads = 0;  ///< correspondence search threads (0: all cores)
};

struct IcpResult {
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();  ///< scan frame -> map frame
  int iterations = 0;
  IcpConvergence convergence = IcpConvergence::NotConverged;
  bool converged = false;        ///< as PCL's hasConverged(): every state but NotConverged/NoCorrespondences
  std::size_t valid_points = 0;  ///< finite scan points
  std::size_t correspondences = 0;  ///< of the last iteration
  double mse = 0.0;                 ///< mean squared distance of the last iteration's correspondences
  double search_seconds = 0.0;      ///< spent in the correspondence search
};

/// Buffers kept between calls: no allocation per iteration, and the warm starts. `hints[i]` is scan
/// point i's last nearest-vertex hint; it survives across calls, so the next frame's point i starts
/// where this frame's point i ended (the scans of a spinning LiDAR keep their point order).
struct IcpWorkspace {
  std::vector<index_t> hints;
  std::vector<float> moved;  ///< the scan at the current estimate, 3 floats per point
  std::vector<std::int32_t> match;
  std::vector<float> dist2;
  /// The worker threads of every pass, kept from call to call: each thread's search scratch (visit
  /// stamps, one per map vertex: 40 MB on a 10M-point map) is then allocated once, not by fresh
  /// threads in every pass. Made on first use for num_threads > 1; calls on one workspace must not
  /// overlap (they may come from different threads one after another).
  std::unique_ptr<ThreadTeam> team;
  unsigned team_threads = 0;  ///< the size `team` was asked for
};

/// Registers `scan` (n points, 3 floats each, non-finite points ignored) onto the map starting from
/// `guess`. `map_normals` (3 floats per map point, unit or zero) is required for point-to-plane and
/// ignored otherwise. Never throws for bad geometry: too few correspondences gives NoCorrespondences
/// and the transform reached so far. Throws dw::Error for a missing normals array or bad options.
IcpResult alignIcp(const CorrespondenceSearch& map, const float* map_normals, const float* scan,
                   std::size_t n, const Eigen::Matrix4d& guess, const IcpOptions& options,
                   IcpWorkspace& workspace);

}  // namespace dw
