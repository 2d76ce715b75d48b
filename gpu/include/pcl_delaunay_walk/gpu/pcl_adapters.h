/// \file pcl_adapters.h
/// \brief The GPU module's PCL face (pcl::gpu): thin adapters between PCL types and the PCL-free
/// dw::gpu engine: clouds as point views (no copy), Eigen <-> row-major transforms, and ICP settings
/// read off a configured pcl::IterativeClosestPoint. Header-only and never included by gpu/src, so the
/// GPU library itself builds without PCL; include it only where PCL is available. It defines nothing
/// PCL's own GPU module defines (pcl/gpu/containers), so one translation unit can include both.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/registration/icp.h>

#include <Eigen/Core>
#include <type_traits>

#include "pcl_delaunay_walk/core/graph/point_view.h"
#include "pcl_delaunay_walk/gpu/iterative_closest_point.h"

namespace pcl {
namespace gpu {

/// The pcl_gpu-style classes under the names PCL users look for; the engine is PCL-free (dw::gpu).
using dw::gpu::DelaunayWalk;
using dw::gpu::IterativeClosestPoint;

/// \brief The xyz of a PCL cloud as a strided float view (the cloud must outlive the view).
/// \param[in] cloud any point type with float x, y, z members laid out consecutively
template <typename PointT>
dw::PointView toPointView(const pcl::PointCloud<PointT>& cloud) {
  if (cloud.empty()) return dw::PointView::fromFloat(nullptr, 0, sizeof(PointT));
  return dw::PointView::fromFloat(&cloud.points[0].x, cloud.size(), sizeof(PointT));
}

/// \brief Row-major double transform from an Eigen 4x4 (PCL's Matrix4 of any scalar).
template <typename Scalar>
dw::gpu::Matrix4d fromEigen(const Eigen::Matrix<Scalar, 4, 4>& m) {
  dw::gpu::Matrix4d out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[4 * r + c] = double(m(r, c));
  return out;
}

/// \brief Eigen 4x4 (PCL's Registration::Matrix4) from a row-major double transform.
template <typename Scalar = float>
Eigen::Matrix<Scalar, 4, 4> toEigen(const dw::gpu::Matrix4d& m) {
  Eigen::Matrix<Scalar, 4, 4> out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out(r, c) = Scalar(m[4 * r + c]);
  return out;
}

/// \brief The settings of a configured PCL ICP (iterations, epsilons, max correspondence distance), so
/// the GPU loop runs with exactly the criteria the CPU one would.
/// \param[in] icp a pcl::IterativeClosestPoint (or subclass, e.g. the Delaunay-walk ICP)
template <typename PointSource, typename PointTarget, typename Scalar>
dw::gpu::IcpParameters parametersFrom(
    const pcl::IterativeClosestPoint<PointSource, PointTarget, Scalar>& icp) {
  // PCL's getters are not const-qualified in every version: read through a non-const reference.
  auto& r = const_cast<pcl::IterativeClosestPoint<PointSource, PointTarget, Scalar>&>(icp);
  dw::gpu::IcpParameters p;
  p.max_iterations = r.getMaximumIterations();
  p.transformation_epsilon = r.getTransformationEpsilon();
  p.transformation_rotation_epsilon = r.getTransformationRotationEpsilon();
  p.euclidean_fitness_epsilon = r.getEuclideanFitnessEpsilon();
  p.max_correspondence_distance = r.getMaxCorrespondenceDistance();
  p.float_transform_criteria = std::is_same<Scalar, float>::value;
  return p;
}

/// \brief Registers a PCL cloud on the GPU: sets it as the only source of `icp` and aligns from `guess`.
/// \param[in,out] icp a GPU ICP whose target is already on the device
/// \param[in] source the cloud to move onto the target
/// \param[in] guess initial transform (PCL's align(output, guess))
/// \param[out] final_transformation the result as PCL returns it (getFinalTransformation())
template <typename PointT, typename Scalar>
dw::gpu::IcpResult align(dw::gpu::IterativeClosestPoint& icp, const pcl::PointCloud<PointT>& source,
                         const Eigen::Matrix<Scalar, 4, 4>& guess,
                         Eigen::Matrix<Scalar, 4, 4>& final_transformation) {
  icp.setInputSource(toPointView(source));
  const dw::gpu::IcpResult r = icp.align(fromEigen(guess));
  final_transformation = toEigen<Scalar>(r.transformation);
  return r;
}

}  // namespace gpu
}  // namespace pcl
