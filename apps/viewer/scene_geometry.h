/// \file scene_geometry.h
/// \brief VTK geometry of the overlays: line sets (correspondences, Delaunay edges, walk paths),
/// marker points and the height-coloured TIN. Built directly as vtkPolyData because PCL's shape
/// helpers add one actor per line, which does not scale to a whole Delaunay graph.
#pragma once

#include <pcl/correspondence.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <vtkCellArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkUnsignedCharArray.h>

#include <array>
#include <cstdint>
#include <vector>

#include "colour_map.h"
#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"

namespace dw_viewer {

/// Segments as endpoint pairs: 6 floats per segment.
using Segments = std::vector<float>;

/// One vtkPolyData of independent line segments.
inline vtkSmartPointer<vtkPolyData> makeLines(const Segments& seg) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToFloat();
  auto lines = vtkSmartPointer<vtkCellArray>::New();
  const vtkIdType n = static_cast<vtkIdType>(seg.size() / 6);
  points->SetNumberOfPoints(2 * n);
  for (vtkIdType s = 0; s < n; ++s) {
    points->SetPoint(2 * s, seg[6 * s], seg[6 * s + 1], seg[6 * s + 2]);
    points->SetPoint(2 * s + 1, seg[6 * s + 3], seg[6 * s + 4], seg[6 * s + 5]);
    const vtkIdType ids[2] = {2 * s, 2 * s + 1};
    lines->InsertNextCell(2, ids);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetLines(lines);
  return poly;
}

/// One vtkPolyData of marker points (3 floats each), optionally one colour per point.
inline vtkSmartPointer<vtkPolyData> makePoints(const std::vector<float>& xyz,
                                               const std::vector<Rgb>& colours = {}) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToFloat();
  auto verts = vtkSmartPointer<vtkCellArray>::New();
  const vtkIdType n = static_cast<vtkIdType>(xyz.size() / 3);
  points->SetNumberOfPoints(n);
  for (vtkIdType i = 0; i < n; ++i) {
    points->SetPoint(i, xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    verts->InsertNextCell(1, &i);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetVerts(verts);
  if (colours.size() == static_cast<std::size_t>(n)) {
    auto rgb = vtkSmartPointer<vtkUnsignedCharArray>::New();
    rgb->SetNumberOfComponents(3);
    rgb->SetName("rgb");
    rgb->SetNumberOfTuples(n);
    for (vtkIdType i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) rgb->SetValue(3 * i + c, colours[i][c]);
    poly->GetPointData()->SetScalars(rgb);
  }
  return poly;
}

/// Correspondence lines, at most `max_lines` of them: every n-th one beyond that, so the picture
/// stays readable and fast while still covering the whole cloud.
inline Segments correspondenceSegments(const pcl::PointCloud<pcl::PointXYZ>& source,
                                       const pcl::PointCloud<pcl::PointXYZ>& target,
                                       const pcl::Correspondences& corr, std::size_t max_lines) {
  Segments seg;
  if (corr.empty() || max_lines == 0) return seg;
  const std::size_t every = (corr.size() + max_lines - 1) / max_lines;
  seg.reserve(6 * (corr.size() / every + 1));
  for (std::size_t k = 0; k < corr.size(); k += every) {
    const auto& s = source[corr[k].index_query];
    const auto& t = target[corr[k].index_match];
    seg.insert(seg.end(), {s.x, s.y, s.z, t.x, t.y, t.z});
  }
  return seg;
}

/// Where the viewer draws vertex v of a graph built from `cloud` (input i = cloud index i): the
/// cloud's own coordinates of v's representative, so overlays sit exactly on the drawn points.
inline const pcl::PointXYZ& vertexPoint(const dw::DelaunayGraph& g,
                                        const pcl::PointCloud<pcl::PointXYZ>& cloud, dw::index_t v) {
  return cloud[g.representative(v)];
}

/// The Delaunay edges of vertex v (seed Fig. 4: a point and its natural neighbours).
inline Segments vertexEdgeSegments(const dw::DelaunayGraph& g, const pcl::PointCloud<pcl::PointXYZ>& cloud,
                                   dw::index_t v) {
  Segments seg;
  const auto& a = vertexPoint(g, cloud, v);
  for (dw::index_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k) {
    const auto& b = vertexPoint(g, cloud, g.edges[k].j);
    seg.insert(seg.end(), {a.x, a.y, a.z, b.x, b.y, b.z});
  }
  return seg;
}

/// Every undirected edge of the graph once (i < j). The caller checks the size first.
inline Segments graphSegments(const dw::DelaunayGraph& g, const pcl::PointCloud<pcl::PointXYZ>& cloud) {
  Segments seg;
  seg.reserve(3 * g.numDirectedEdges());
  for (dw::index_t v = 0; v < g.numVertices(); ++v)
    for (dw::index_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k) {
      const dw::index_t j = g.edges[k].j;
      if (j <= v) continue;
      const auto& a = vertexPoint(g, cloud, v);
      const auto& b = vertexPoint(g, cloud, j);
      seg.insert(seg.end(), {a.x, a.y, a.z, b.x, b.y, b.z});
    }
  return seg;
}

/// Consecutive segments along a vertex path (a walk).
inline Segments pathSegments(const dw::DelaunayGraph& g, const pcl::PointCloud<pcl::PointXYZ>& cloud,
                             const std::vector<dw::index_t>& path) {
  Segments seg;
  for (std::size_t k = 1; k < path.size(); ++k) {
    const auto& a = vertexPoint(g, cloud, path[k - 1]);
    const auto& b = vertexPoint(g, cloud, path[k]);
    seg.insert(seg.end(), {a.x, a.y, a.z, b.x, b.y, b.z});
  }
  return seg;
}

/// A triangle mesh as vtkPolyData with one RGB colour per vertex. `xyz` is already in the display
/// frame (floats near the origin).
inline vtkSmartPointer<vtkPolyData> makeColouredMesh(const std::vector<float>& xyz,
                                                     const std::vector<std::uint32_t>& triangles,
                                                     const std::vector<Rgb>& colours) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToFloat();
  const vtkIdType n = static_cast<vtkIdType>(xyz.size() / 3);
  points->SetNumberOfPoints(n);
  for (vtkIdType i = 0; i < n; ++i) points->SetPoint(i, xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  auto polys = vtkSmartPointer<vtkCellArray>::New();
  polys->AllocateEstimate(static_cast<vtkIdType>(triangles.size() / 3), 3);
  for (std::size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const vtkIdType ids[3] = {triangles[t], triangles[t + 1], triangles[t + 2]};
    polys->InsertNextCell(3, ids);
  }
  auto rgb = vtkSmartPointer<vtkUnsignedCharArray>::New();
  rgb->SetNumberOfComponents(3);
  rgb->SetName("rgb");
  rgb->SetNumberOfTuples(n);
  for (vtkIdType i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) rgb->SetValue(3 * i + c, colours[i][c]);
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetPolys(polys);
  poly->GetPointData()->SetScalars(rgb);
  return poly;
}

}  // namespace dw_viewer
