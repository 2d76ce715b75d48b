#include "pcl_delaunay_walk/core/registration/map_normals.h"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {

std::vector<float> computeMapNormals(const CallerMetricSearch& search, std::size_t k, unsigned threads) {
  if (k < 3) throw Error("dw::computeMapNormals: k must be >= 3");
  const std::size_t n = search.numInputs();
  const std::vector<float>& xyz = search.inputXyz();
  std::vector<float> normals(3 * n, 0.f);
  parallelFor(n, workerCount(n, threads, 1024), [&](std::size_t b, std::size_t e, unsigned) {
    std::vector<WalkNeighbour> nbs;
    index_t hint = kInvalidIndex;
    for (std::size_t i = b; i < e; ++i) {
      const float* q = &xyz[3 * i];
      CallerMetricSearchStats stats;
      const std::size_t found = search.knn(q, k, StartStrategy::PnnOptimized, hint, nbs, &stats);
      if (found == 0) continue;  // a non-finite input
      hint = stats.nn_vertex;    // inputs are near their predecessors: a short walk from there
      if (found < 3) continue;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (std::size_t j = 0; j < found; ++j) {
        const float* p = &xyz[3 * std::size_t(nbs[j].index)];
        mean += Eigen::Vector3d(p[0], p[1], p[2]);
      }
      mean /= double(found);
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (std::size_t j = 0; j < found; ++j) {
        const float* p = &xyz[3 * std::size_t(nbs[j].index)];
        const Eigen::Vector3d d = Eigen::Vector3d(p[0], p[1], p[2]) - mean;
        cov += d * d.transpose();
      }
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
      eig.computeDirect(cov);
      const Eigen::Vector3d ev = eig.eigenvalues();
      // A line or a point has no plane: two vanishing eigenvalues.
      if (!(ev(1) > 1e-12 * std::max(ev(2), 1e-300))) continue;
      const Eigen::Vector3d nrm = eig.eigenvectors().col(0).normalized();
      if (!nrm.allFinite()) continue;
      for (int c = 0; c < 3; ++c) normals[3 * i + std::size_t(c)] = static_cast<float>(nrm(c));
    }
  });
  return normals;
}

}  // namespace dw
