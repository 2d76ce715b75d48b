/// \file pcl_kdtree_peer.cpp
/// \brief PCL's pcl::search::KdTree (FLANN) as a peer of the PCL-free driver dw_peers: built only where
/// PCL is, and the only unit of dw_peers that links PCL.
// GCC 12's -Warray-bounds false positives inside Eigen's Umeyama (PCL's SVD step) at -march=native;
// see dw_bench.cpp. This must precede every include.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif

#include <pcl/pcl_config.h>
#include <pcl/registration/icp.h>

#include <chrono>

#include "common/nn_methods.h"
#include "peers/peers.h"

namespace dwb {

std::unique_ptr<NnMethod> makePclKdTree() {
  struct Named : PclKdTreeNn {
    std::string name() const override { return "pcl-kdtree-" PCL_VERSION_PRETTY; }
    std::string version() const override { return PCL_VERSION_PRETTY " (FLANN)"; }
  };
  return std::make_unique<Named>();
}

PeerIcpResult pclStockIcp(const std::vector<float>& source, const std::vector<float>& target, double max_dist,
                          int max_iterations) {
  const auto src = toCloud(source), tgt = toCloud(target);
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setMaximumIterations(max_iterations);
  icp.setTransformationEpsilon(1e-11);
  icp.setEuclideanFitnessEpsilon(1e-11);
  icp.setMaxCorrespondenceDistance(max_dist);
  pcl::PointCloud<pcl::PointXYZ> out;
  const double t0 = processCpuSeconds();
  icp.setInputSource(src);
  icp.setInputTarget(tgt);
  icp.align(out);
  PeerIcpResult r;
  r.seconds = processCpuSeconds() - t0;
  r.pose = icp.getFinalTransformation().cast<double>();
  r.converged = icp.hasConverged();
  r.iterations = -1;  // PCL does not report its count
  return r;
}

}  // namespace dwb
