/// \file peers.h
/// \brief The 2026 peers of the exact searches, behind the batch interface of common/nn_method.h:
/// nanoflann 1.12.1 and Debian's 1.4.3 (each in its own translation unit and namespace, so that both
/// live in one process), pico_tree, small_gicp's KdTree, and PCL's FLANN KdTree where PCL is built.
/// Benchmark-only: never linked into the library, its tests or its install (bench/CMakeLists.txt
/// finds them under DW_PEERS_DIR and leaves out, saying so, each that is absent).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "common/nn_method.h"

namespace dwb {

/// The peers compiled into this program, in report order ("nanoflann-1.12.1", "pico_tree-1.0.0", ...).
std::vector<std::string> peerNames();
/// Peers this program was built without, each with the reason ("pico_tree: not found under ...").
std::vector<std::string> missingPeers();
/// A peer by name; nullptr when it is not compiled in.
std::unique_ptr<NnMethod> makePeer(const std::string& name);

/// A peer's own registration, timed whole (its structures and covariances included).
struct PeerIcpResult {
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();  ///< target ~ pose * source
  int iterations = 0;
  bool converged = false;
  double seconds = 0;       ///< whole call, process CPU time (one thread)
  double prep_seconds = 0;  ///< of it: trees and covariances
};

/// small_gicp's own ICP (point-to-point factor) or GICP (covariances from 10 neighbours, its README's
/// setting), one thread (SerialReduction), no downsampling, its default optimiser (Levenberg-Marquardt)
/// and termination criteria, pairs beyond max_dist rejected.
PeerIcpResult smallGicpAlign(const std::vector<float>& source, const std::vector<float>& target, bool gicp,
                             double max_dist, int max_iterations);
/// Stock pcl::IterativeClosestPoint (its own FLANN KdTree, built inside align()), PCL's SVD step,
/// epsilons 1e-11, pairs beyond max_dist rejected. Compiled only with PCL (DW_PEER_PCL).
PeerIcpResult pclStockIcp(const std::vector<float>& source, const std::vector<float>& target, double max_dist,
                          int max_iterations);

// One factory per peer translation unit (bench/peers/*.cpp).
std::unique_ptr<NnMethod> makeNanoflannNew();
std::unique_ptr<NnMethod> makeNanoflannDebian();
std::unique_ptr<NnMethod> makePicoTree();
std::unique_ptr<NnMethod> makeSmallGicpKdTree();
std::unique_ptr<NnMethod> makePclKdTree();

}  // namespace dwb
