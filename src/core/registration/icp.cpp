#include "pcl_delaunay_walk/core/registration/icp.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <string>

#include "core/registration/rigid_estimation.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {

const char* toString(IcpConvergence c) {
  switch (c) {
    case IcpConvergence::NotConverged: return "not converged";
    case IcpConvergence::Iterations: return "iterations";
    case IcpConvergence::Transform: return "transform";
    case IcpConvergence::AbsoluteMse: return "absolute MSE";
    case IcpConvergence::RelativeMse: return "relative MSE";
    case IcpConvergence::NoCorrespondences: return "no correspondences";
  }
  return "?";
}

namespace {

using registration_detail::PointToPlaneSums;
using registration_detail::PointToPointSums;

// Correspondences are summed in blocks of this many scan points, added in block order: the sums, and
// so the poses, are the same for every thread count.
constexpr std::size_t kBlock = 2048;

bool finite3(const float* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

/// x' = T x rounded to float, with PCL's operation order for a double transform (translation first,
/// then the x, y, z columns), so the moved scan is pcl::transformPointCloud's to the bit.
void moveInPlace(float* xyz, std::size_t n, const Eigen::Matrix4d& t, unsigned threads) {
  parallelFor(n, workerCount(n, threads, 16384), [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t i = b; i < e; ++i) {
      float* p = xyz + 3 * i;
      const double x = p[0], y = p[1], z = p[2];
      for (int r = 0; r < 3; ++r) {
        double v = t(r, 3);
        v = x * t(r, 0) + v;
        v = y * t(r, 1) + v;
        v = z * t(r, 2) + v;
        p[r] = static_cast<float>(v);
      }
    }
  });
}

double kernelWeight(const IcpOptions& o, double r) {
  const double a = std::fabs(r), k = o.kernel_scale;
  switch (o.kernel) {
    case RobustKernel::None: return 1.0;
    case RobustKernel::Huber: return a <= k ? 1.0 : k / a;
    case RobustKernel::Cauchy: return 1.0 / (1.0 + (r / k) * (r / k));
  }
  return 1.0;
}

void checkOptions(const IcpOptions& o, const float* normals) {
  if (o.metric == IcpMetric::PointToPlane && normals == nullptr)
    throw Error("dw::alignIcp: point-to-plane needs the map normals");
  if (o.max_iterations < 1) throw Error("dw::alignIcp: max_iterations must be >= 1");
  if (!(o.max_correspondence_distance > 0))
    throw Error("dw::alignIcp: max_correspondence_distance must be > 0");
  if (o.kernel != RobustKernel::None && !(o.kernel_scale > 0 && std::isfinite(o.kernel_scale)))
    throw Error("dw::alignIcp: the robust kernel needs a finite kernel_scale > 0");
}

/// PCL's DefaultConvergenceCriteria with max_iterations_similar_transforms 0 (its default): one
/// similar iteration converges.
class ConvergenceTest {
 public:
  explicit ConvergenceTest(const IcpOptions& o)
      : o_(o), rotation_(o.rotation_epsilon > 0 ? o.rotation_epsilon : 1.0 - o.transformation_epsilon) {}

  IcpConvergence check(int iterations, const Eigen::Matrix4d& increment, double mse) {
    if (iterations >= o_.max_iterations) return IcpConvergence::Iterations;
    const double cos_angle = 0.5 * (increment(0, 0) + increment(1, 1) + increment(2, 2) - 1);
    const double t2 = increment.topRightCorner<3, 1>().squaredNorm();
    if (cos_angle >= rotation_ && t2 <= o_.transformation_epsilon) return IcpConvergence::Transform;
    const double change = std::fabs(mse - previous_mse_);
    if (change < o_.absolute_mse_epsilon) return IcpConvergence::AbsoluteMse;
    if (change / previous_mse_ < o_.euclidean_fitness_epsilon) return IcpConvergence::RelativeMse;
    previous_mse_ = mse;
    return IcpConvergence::NotConverged;
  }

 private:
  const IcpOptions& o_;
  double rotation_;
  double previous_mse_ = std::numeric_limits<double>::max();
};

struct BlockSums {
  PointToPointSums p2p;
  PointToPlaneSums p2l;
  double sum_d2 = 0.0;
  std::size_t count = 0;
};

/// One iteration's correspondences and the sums of its estimator.
class CorrespondencePass {
 public:
  CorrespondencePass(const CorrespondenceSearch& map, const float* normals, const IcpOptions& o,
                     IcpWorkspace& ws, std::size_t n)
      : map_(map), normals_(normals), o_(o), ws_(ws), n_(n), blocks_((n + kBlock - 1) / kBlock) {
    const double md = o.max_correspondence_distance;
    max_d2_ = md * md;  // PCL compares the float distance promoted to double with this square
  }

  void search(unsigned threads) {
    parallelForDynamic(blocks_.size(), workerCount(n_, threads, kBlock), [&](std::size_t b) {
      const std::size_t begin = b * kBlock, end = std::min(n_, begin + kBlock);
      for (std::size_t i = begin; i < end; ++i) {
        if (i + 4 < end) map_.prefetch(ws_.hints[i + 4]);
        const float* q = &ws_.moved[3 * i];
        std::int32_t idx = -1;
        float d2 = 0.f;
        index_t& start = ws_.hints[i];
        if (i > begin) start = map_.closerStart(q, start, ws_.hints[i - 1]);
        if (!map_.nearest(q, start, idx, d2) || !(double(d2) <= max_d2_)) idx = -1;
        ws_.match[i] = idx;
        ws_.dist2[i] = d2;
      }
    });
  }

  /// Sums every block on `threads` threads; returns their total (in block order).
  BlockSums accumulate(unsigned threads) {
    ref_set_ = false;
    for (std::size_t i = 0; i < n_ && !ref_set_; ++i)
      if (ws_.match[i] >= 0) {
        ref_p_ = vec(&ws_.moved[3 * i]);
        ref_q_ = vec(map_.point(std::size_t(ws_.match[i])));
        ref_set_ = true;
      }
    parallelForDynamic(blocks_.size(), workerCount(n_, threads, kBlock), [&](std::size_t b) {
      BlockSums s;
      const std::size_t begin = b * kBlock, end = std::min(n_, begin + kBlock);
      for (std::size_t i = begin; i < end; ++i) addOne(i, s);
      blocks_[b] = s;
    });
    BlockSums total;
    for (const BlockSums& s : blocks_) {
      total.p2p.add(s.p2p);
      total.p2l.add(s.p2l);
      total.sum_d2 += s.sum_d2;
      total.count += s.count;
    }
    return total;
  }

  Eigen::Matrix4d solve(const BlockSums& total) const {
    if (o_.metric == IcpMetric::PointToPlane)
      return registration_detail::solvePointToPlane(total.p2l, ref_p_);
    return registration_detail::solvePointToPoint(total.p2p, ref_p_, ref_q_);
  }

 private:
  static Eigen::Vector3d vec(const float* p) { return {double(p[0]), double(p[1]), double(p[2])}; }

  void addOne(std::size_t i, BlockSums& s) const {
    const std::int32_t m = ws_.match[i];
    if (m < 0) return;
    ++s.count;
    s.sum_d2 += ws_.dist2[i];
    const Eigen::Vector3d p = vec(&ws_.moved[3 * i]) - ref_p_;
    if (o_.metric == IcpMetric::PointToPoint) {
      const Eigen::Vector3d q = vec(map_.point(std::size_t(m))) - ref_q_;
      const double w =
          o_.kernel == RobustKernel::None ? 1.0 : kernelWeight(o_, std::sqrt(double(ws_.dist2[i])));
      s.p2p.add(p, q, w);
      return;
    }
    const float* nf = normals_ + 3 * std::size_t(m);
    const Eigen::Vector3d nrm(nf[0], nf[1], nf[2]);
    if (nrm.squaredNorm() == 0) return;  // no plane there (too few or collinear neighbours)
    const double r = nrm.dot(vec(&ws_.moved[3 * i]) - vec(map_.point(std::size_t(m))));
    s.p2l.add(p, nrm, r, kernelWeight(o_, r));
  }

  const CorrespondenceSearch& map_;
  const float* normals_;
  const IcpOptions& o_;
  IcpWorkspace& ws_;
  std::size_t n_;
  std::vector<BlockSums> blocks_;
  double max_d2_;
  bool ref_set_ = false;
  Eigen::Vector3d ref_p_ = Eigen::Vector3d::Zero(), ref_q_ = Eigen::Vector3d::Zero();
};

}  // namespace

IcpResult alignIcp(const CorrespondenceSearch& map, const float* map_normals, const float* scan,
                   std::size_t n, const Eigen::Matrix4d& guess, const IcpOptions& options, IcpWorkspace& ws) {
  checkOptions(options, map_normals);
  const unsigned threads = resolveThreads(options.num_threads);
  if (threads > 1 && (!ws.team || ws.team_threads != threads)) {
    ws.team.reset();
    ws.team = std::make_unique<ThreadTeam>(threads);
    ws.team_threads = threads;
  }
  std::optional<ThreadTeam::Scope> on_team;
  if (threads > 1) on_team.emplace(*ws.team);
  IcpResult result;
  result.transform = guess;
  // Non-finite points are dropped once, so that the workspace holds only what the search reads.
  ws.moved.clear();
  for (std::size_t i = 0; i < n; ++i)
    if (finite3(scan + 3 * i)) ws.moved.insert(ws.moved.end(), scan + 3 * i, scan + 3 * i + 3);
  const std::size_t m = ws.moved.size() / 3;
  result.valid_points = m;
  ws.hints.resize(std::max(ws.hints.size(), m), kInvalidIndex);
  ws.match.assign(m, -1);
  ws.dist2.assign(m, 0.f);
  if (!guess.isIdentity(0.0)) moveInPlace(ws.moved.data(), m, guess, threads);

  CorrespondencePass pass(map, map_normals, options, ws, m);
  ConvergenceTest convergence(options);
  using Clock = std::chrono::steady_clock;
  for (;;) {
    const auto t0 = Clock::now();
    pass.search(threads);
    result.search_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    const BlockSums total = pass.accumulate(threads);
    result.correspondences = total.count;
    result.mse = total.count ? total.sum_d2 / double(total.count) : 0.0;
    if (total.count < std::max<std::size_t>(options.min_correspondences, 1)) {
      result.convergence = IcpConvergence::NoCorrespondences;
      break;
    }
    const Eigen::Matrix4d increment = pass.solve(total);
    moveInPlace(ws.moved.data(), m, increment, threads);
    result.transform = increment * result.transform;
    ++result.iterations;
    result.convergence = convergence.check(result.iterations, increment, result.mse);
    if (result.convergence != IcpConvergence::NotConverged) break;
  }
  result.converged = result.convergence != IcpConvergence::NotConverged &&
                     result.convergence != IcpConvergence::NoCorrespondences;
  return result;
}

}  // namespace dw
