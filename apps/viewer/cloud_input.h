/// \file cloud_input.h
/// \brief Reading the viewer's inputs: clouds (PCD/PLY, x/y/z of any numeric type; LAS through the
/// project's pcl::io::loadLASFile), kept in double until a display origin is chosen, and TIN meshes
/// (PLY faces, as dw_tin writes them).
///
/// PCL's fromPCLPointCloud2 maps fields only when their types match PointXYZ's floats, so a PLY with
/// double coordinates (what a georeferenced TIN needs) would come back empty; hence the field reader.
#pragma once

#include <pcl/PCLPointCloud2.h>
#include <pcl/PolygonMesh.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "core/util/file_header_check.h"
#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/io/las_io.h"

namespace dw_viewer {

/// Finite points of a file in double precision; `input_index` maps each back to its row in the file.
struct XyzPoints {
  std::vector<double> xyz;  ///< 3 per point
  std::vector<std::uint32_t> input_index;
  std::size_t skipped = 0;  ///< rows with a NaN/Inf coordinate

  std::size_t size() const { return xyz.size() / 3; }
};

/// A triangle mesh: vertex coordinates (double) and triangles as vertex triples.
struct TriangleMesh {
  std::vector<double> xyz;
  std::vector<std::uint32_t> triangles;

  std::size_t numVertices() const { return xyz.size() / 3; }
  std::size_t numTriangles() const { return triangles.size() / 3; }
};

namespace detail {

inline std::string lowerExtension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  const auto slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

/// Value of one scalar field element as double, whatever its stored type.
inline double readScalar(const std::uint8_t* p, std::uint8_t datatype) {
  switch (datatype) {
    case pcl::PCLPointField::INT8: {
      std::int8_t v;
      std::memcpy(&v, p, 1);
      return v;
    }
    case pcl::PCLPointField::UINT8: {
      std::uint8_t v;
      std::memcpy(&v, p, 1);
      return v;
    }
    case pcl::PCLPointField::INT16: {
      std::int16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case pcl::PCLPointField::UINT16: {
      std::uint16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case pcl::PCLPointField::INT32: {
      std::int32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case pcl::PCLPointField::UINT32: {
      std::uint32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case pcl::PCLPointField::FLOAT32: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case pcl::PCLPointField::FLOAT64: {
      double v;
      std::memcpy(&v, p, 8);
      return v;
    }
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

inline std::size_t scalarSize(std::uint8_t datatype) {
  switch (datatype) {
    case pcl::PCLPointField::INT8:
    case pcl::PCLPointField::UINT8: return 1;
    case pcl::PCLPointField::INT16:
    case pcl::PCLPointField::UINT16: return 2;
    case pcl::PCLPointField::INT32:
    case pcl::PCLPointField::UINT32:
    case pcl::PCLPointField::FLOAT32: return 4;
    case pcl::PCLPointField::FLOAT64: return 8;
    default: return 0;
  }
}

/// Reads blob from a PCD or PLY file (and, for PLY, the faces when `mesh` is given).
inline void loadBlob(const std::string& path, pcl::PCLPointCloud2& blob, pcl::PolygonMesh* mesh) {
  const std::string ext = lowerExtension(path);
  int rc = -1;
  if (ext == "pcd" || ext == "ply") {
    try {  // PCL 1.13 crashes on some malformed headers (docs/robustness.md)
      dw::checkPointFileHeader(path);
    } catch (const dw::Error& e) {
      throw dw::Error(std::string("dw_viewer: cannot read ") + e.what());
    }
  }
  if (ext == "pcd") {
    pcl::PCDReader reader;
    rc = reader.read(path, blob);
  } else if (ext == "ply") {
    if (mesh) {
      rc = pcl::io::loadPLYFile(path, *mesh);
      blob = mesh->cloud;
    } else {
      rc = pcl::io::loadPLYFile(path, blob);
    }
  } else {
    throw dw::Error("dw_viewer: " + path + ": unknown file type (expected .pcd, .ply, .las or .laz)");
  }
  if (rc < 0) throw dw::Error("dw_viewer: cannot read " + path + " (missing, unreadable or malformed)");
}

}  // namespace detail

/// Finite x, y, z of every point of a loaded blob (any numeric field type, organised or not).
inline XyzPoints extractXyz(const pcl::PCLPointCloud2& blob, const std::string& what) {
  const pcl::PCLPointField* f[3] = {nullptr, nullptr, nullptr};
  const char* names[3] = {"x", "y", "z"};
  for (const auto& field : blob.fields)
    for (int k = 0; k < 3; ++k)
      if (field.name == names[k]) f[k] = &field;
  for (int k = 0; k < 3; ++k) {
    if (!f[k]) throw dw::Error("dw_viewer: " + what + " has no '" + names[k] + "' field");
    const std::size_t size = detail::scalarSize(f[k]->datatype);
    if (size == 0) throw dw::Error("dw_viewer: " + what + ": field '" + names[k] + "' has an unknown type");
    if (f[k]->offset + size > blob.point_step)
      throw dw::Error("dw_viewer: " + what + ": field '" + names[k] + "' lies outside the point record");
  }
  const std::size_t rows = blob.height, cols = blob.width;
  if (rows * cols > 0 && (static_cast<std::size_t>(blob.row_step) < cols * blob.point_step ||
                          blob.data.size() < rows * static_cast<std::size_t>(blob.row_step)))
    throw dw::Error("dw_viewer: " + what + ": point data is shorter than its header says");
  if (rows * cols > std::numeric_limits<std::uint32_t>::max())
    throw dw::Error("dw_viewer: " + what + ": too many points");
  XyzPoints out;
  out.xyz.reserve(3 * rows * cols);
  out.input_index.reserve(rows * cols);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < cols; ++c) {
      const std::uint8_t* rec = blob.data.data() + r * blob.row_step + c * blob.point_step;
      double v[3];
      for (int k = 0; k < 3; ++k) v[k] = detail::readScalar(rec + f[k]->offset, f[k]->datatype);
      if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
        ++out.skipped;
        continue;
      }
      out.xyz.insert(out.xyz.end(), v, v + 3);
      out.input_index.push_back(static_cast<std::uint32_t>(r * cols + c));
    }
  return out;
}

/// Points of a LAS file (world coordinates), optionally only one class (2 = ground).
inline XyzPoints loadLas(const std::string& path, int classification) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  pcl::io::LASLoadOptions options;
  options.classification = classification;
  // Centred floats, then back to double: exact to float spacing near the tile centre (sub-mm for a
  // tile), where world coordinates in float would be off by up to 0.5 m.
  if (pcl::io::loadLASFile(path, cloud, &origin, options) < 0)
    throw dw::Error("dw_viewer: cannot read " + path);
  XyzPoints pts;
  pts.xyz.reserve(3 * cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      ++pts.skipped;
      continue;
    }
    pts.xyz.insert(pts.xyz.end(), {p.x + origin[0], p.y + origin[1], p.z + origin[2]});
    pts.input_index.push_back(static_cast<std::uint32_t>(i));
  }
  return pts;
}

/// Loads the finite points of a PCD, PLY or LAS file (`las_class` >= 0: only that LAS class).
/// Throws dw::Error on a missing/foreign/empty file.
inline XyzPoints loadXyz(const std::string& path, int las_class = -1) {
  if (detail::lowerExtension(path) == "las" || detail::lowerExtension(path) == "laz") {
    XyzPoints pts = loadLas(path, las_class);
    if (pts.size() == 0) throw dw::Error("dw_viewer: " + path + " has no points (of the requested class)");
    return pts;
  }
  pcl::PCLPointCloud2 blob;
  detail::loadBlob(path, blob, nullptr);
  XyzPoints pts = extractXyz(blob, path);
  if (pts.size() == 0) throw dw::Error("dw_viewer: " + path + " has no finite points");
  return pts;
}

/// Loads a PLY mesh; polygons with more than 3 vertices are fanned into triangles. A PLY without
/// faces, a PCD or a LAS file gives a mesh with no triangles (the caller may triangulate it).
/// Non-finite vertices and faces that use them are dropped; an out-of-range face index is an error.
inline TriangleMesh loadMesh(const std::string& path, int las_class = -1) {
  const std::string ext = detail::lowerExtension(path);
  if (ext != "ply") {
    TriangleMesh cloud_only;
    cloud_only.xyz = loadXyz(path, las_class).xyz;
    return cloud_only;
  }
  pcl::PCLPointCloud2 blob;
  pcl::PolygonMesh pm;
  detail::loadBlob(path, blob, ext == "ply" ? &pm : nullptr);
  const XyzPoints pts = extractXyz(blob, path);
  if (pts.size() == 0) throw dw::Error("dw_viewer: " + path + " has no finite vertices");
  TriangleMesh mesh;
  mesh.xyz = pts.xyz;
  const std::size_t rows = static_cast<std::size_t>(blob.width) * blob.height;
  // File row -> kept vertex (or invalid for a dropped non-finite one).
  std::vector<std::uint32_t> row_to_vertex(rows, dw::kInvalidIndex);
  for (std::size_t v = 0; v < pts.input_index.size(); ++v)
    row_to_vertex[pts.input_index[v]] = static_cast<std::uint32_t>(v);
  for (const auto& poly : pm.polygons) {
    const auto& ids = poly.vertices;
    if (ids.size() < 3) continue;
    for (auto id : ids)
      if (id < 0 || static_cast<std::size_t>(id) >= rows)
        throw dw::Error("dw_viewer: " + path + ": a face uses vertex " + std::to_string(id) + " of " +
                        std::to_string(rows));
    for (std::size_t k = 1; k + 1 < ids.size(); ++k) {
      const std::uint32_t a = row_to_vertex[ids[0]], b = row_to_vertex[ids[k]], c = row_to_vertex[ids[k + 1]];
      if (a == dw::kInvalidIndex || b == dw::kInvalidIndex || c == dw::kInvalidIndex) continue;
      mesh.triangles.insert(mesh.triangles.end(), {a, b, c});
    }
  }
  return mesh;
}

/// Display origin: coordinates are drawn (and ICP runs) relative to it, so that georeferenced
/// clouds (~6e6 m) keep millimetres in float. Zero for clouds that are already local.
inline std::array<double, 3> chooseOrigin(const std::vector<double>& xyz) {
  std::array<double, 3> lo{{HUGE_VAL, HUGE_VAL, HUGE_VAL}}, hi{{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL}};
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], xyz[i + k]);
      hi[k] = std::max(hi[k], xyz[i + k]);
    }
  std::array<double, 3> origin{{0, 0, 0}};
  if (xyz.empty()) return origin;
  const double magnitude = std::max({std::fabs(lo[0]), std::fabs(lo[1]), std::fabs(lo[2]), std::fabs(hi[0]),
                                     std::fabs(hi[1]), std::fabs(hi[2])});
  // 1e4: below it float spacing is under a millimetre, so shifting would only confuse the user.
  if (magnitude > 1e4)
    for (int k = 0; k < 3; ++k) origin[k] = std::round(0.5 * (lo[k] + hi[k]));
  return origin;
}

/// PointXYZ cloud of `pts` relative to `origin`.
inline pcl::PointCloud<pcl::PointXYZ>::Ptr toCloud(const XyzPoints& pts,
                                                   const std::array<double, 3>& origin) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    auto& p = (*cloud)[i];
    p.x = static_cast<float>(pts.xyz[3 * i] - origin[0]);
    p.y = static_cast<float>(pts.xyz[3 * i + 1] - origin[1]);
    p.z = static_cast<float>(pts.xyz[3 * i + 2] - origin[2]);
  }
  cloud->width = static_cast<std::uint32_t>(cloud->size());
  cloud->height = 1;
  cloud->is_dense = true;
  return cloud;
}

}  // namespace dw_viewer
