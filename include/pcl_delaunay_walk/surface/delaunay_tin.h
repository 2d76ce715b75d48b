/// \file delaunay_tin.h
/// \brief pcl::DelaunayTin: 2.5D Delaunay mesh construction for airborne LiDAR (x, y triangulated, z
/// kept) on top of the core's parallel strip triangulation (dw::tin::triangulate).
#pragma once

#include <pcl/PolygonMesh.h>
#include <pcl/Vertices.h>
#include <pcl/surface/reconstruction.h>

#include <cstdint>
#include <vector>

#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace pcl {

/** \brief Exact Delaunay triangulation of a cloud's (x, y), the z of every point carried along: the
 * TIN of airborne LiDAR. Strips along the long axis are triangulated in parallel and merged pairwise
 * (Song, Li, Liu); cocircular ties are broken by point index, so the mesh does not depend on the
 * thread count. Duplicated (x, y) positions collapse onto the smallest index; points with a
 * non-finite x or y are left out.
 *
 * For big inputs prefer reconstructTriangles(), which returns a compact index array (12 bytes per
 * triangle) instead of a pcl::PolygonMesh (about 60 bytes per triangle plus a copy of the cloud).
 */
template <typename PointInT>
class DelaunayTin : public MeshConstruction<PointInT> {
 public:
  using Ptr = shared_ptr<DelaunayTin<PointInT>>;
  using ConstPtr = shared_ptr<const DelaunayTin<PointInT>>;

  using MeshConstruction<PointInT>::reconstruct;

  /** \brief Constructor: no search tree is built (the triangulation does not need one). */
  DelaunayTin() { this->check_tree_ = false; }

  /** \brief Set the number of threads (0: all hardware threads).
   * \param[in] threads number of worker threads */
  void setNumberOfThreads(unsigned threads) { options_.num_threads = threads; }
  /** \brief Get the number of threads (0: all hardware threads). */
  unsigned getNumberOfThreads() const { return options_.num_threads; }

  /** \brief Set the number of strips (0: automatic, about 1M points per strip and at least
   * two per thread; 1: the sequential kernel).
   * \param[in] strips number of strips along the long axis */
  void setNumberOfStrips(unsigned strips) { options_.num_strips = strips; }
  /** \brief Get the number of strips. */
  unsigned getNumberOfStrips() const { return options_.num_strips; }

  /** \brief Triangulate the input (and indices, if set) into a compact array.
   * \param[out] triangles three cloud indices per triangle, counter-clockwise seen from +z
   * \return false (with PCL_ERROR) when the input is missing */
  bool reconstructTriangles(std::vector<std::uint32_t>& triangles);

  /** \brief Statistics of the last run: timings, strips, duplicates (empty before the first run). */
  const dw::tin::TinResult& getLastResult() const { return last_; }

 protected:
  /** \brief Triangulate into a mesh whose cloud is the whole input cloud. */
  void performReconstruction(pcl::PolygonMesh& output) override;
  /** \brief Triangulate into polygons indexing the input cloud. */
  void performReconstruction(std::vector<pcl::Vertices>& polygons) override;
  std::string getClassName() const override { return "DelaunayTin"; }

 private:
  /** \brief Runs the core triangulation on input_/indices_; triangles are remapped to cloud indices. */
  void triangulate();

  dw::tin::TinOptions options_;
  dw::tin::TinResult last_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include "pcl_delaunay_walk/surface/impl/delaunay_tin.hpp"
#endif
