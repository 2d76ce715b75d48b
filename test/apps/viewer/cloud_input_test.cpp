// dw_viewer's inputs: clouds of any numeric field type with NaN rows skipped, PLY meshes with
// polygons fanned into triangles, georeferenced coordinates shifted, clear errors for bad files;
// and the colour scales the pictures rely on.
#include "viewer/cloud_input.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>

#include "pcl_delaunay_walk/core/las/las_writer.h"
#include "pcl_delaunay_walk/core/las/laz_writer.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"
#include "viewer/colour_map.h"
#include "viewer/scene_geometry.h"

namespace {

std::string tempPath(const std::string& name) {
  return ::testing::TempDir() + "dw_viewer_" + name;
}

template <typename T>
void put(std::vector<std::uint8_t>& data, std::size_t offset, T v) {
  std::memcpy(data.data() + offset, &v, sizeof(T));
}

TEST(CloudInput, ExtractsDoubleAndIntegerFieldsAndSkipsNonFinite) {
  pcl::PCLPointCloud2 blob;
  blob.width = 3;
  blob.height = 1;
  blob.point_step = 20;
  blob.row_step = 60;
  pcl::PCLPointField x, y, z;
  x.name = "x";
  x.offset = 0;
  x.datatype = pcl::PCLPointField::FLOAT64;
  x.count = 1;
  y.name = "y";
  y.offset = 8;
  y.datatype = pcl::PCLPointField::FLOAT64;
  y.count = 1;
  z.name = "z";
  z.offset = 16;
  z.datatype = pcl::PCLPointField::INT32;
  z.count = 1;
  blob.fields = {x, y, z};
  blob.data.assign(60, 0);
  put(blob.data, 0, 6123456.25);
  put(blob.data, 8, 512345.5);
  put(blob.data, 16, std::int32_t(-7));
  put(blob.data, 20, std::numeric_limits<double>::quiet_NaN());
  put(blob.data, 40, 1.0);
  put(blob.data, 48, 2.0);
  put(blob.data, 56, std::int32_t(3));
  const auto pts = dw_viewer::extractXyz(blob, "blob");
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts.skipped, 1u);
  EXPECT_EQ(pts.xyz[0], 6123456.25) << "double precision is kept";
  EXPECT_EQ(pts.xyz[2], -7.0);
  EXPECT_EQ(pts.input_index[1], 2u);

  blob.fields.pop_back();
  EXPECT_THROW(dw_viewer::extractXyz(blob, "blob"), dw::Error);
  blob.fields.push_back(z);
  blob.data.resize(30);
  EXPECT_THROW(dw_viewer::extractXyz(blob, "blob"), dw::Error) << "short data";
}

TEST(CloudInput, LoadsBundledPlyAndRejectsBadFiles) {
  const auto bunny = dw_viewer::loadXyz(std::string(DW_TEST_DATA_DIR) + "/bun000.ply");
  EXPECT_EQ(bunny.size(), 40256u);
  const auto pcd = dw_viewer::loadXyz(std::string(DW_TEST_DATA_DIR) + "/pcl_bun0.pcd");
  EXPECT_GT(pcd.size(), 0u);

  EXPECT_THROW(dw_viewer::loadXyz(tempPath("missing.ply")), dw::Error);
  EXPECT_THROW(dw_viewer::loadXyz(tempPath("cloud.xyz")), dw::Error);
  EXPECT_THROW(dw_viewer::loadXyz(tempPath("missing_tile.LAS")), dw::Error);
  const std::string fake_las = tempPath("fake.las");
  std::ofstream(fake_las) << "LASF but far too short to be a header";
  EXPECT_THROW(dw_viewer::loadXyz(fake_las), dw::Error);
  const std::string garbage = tempPath("garbage.ply");
  std::ofstream(garbage) << "this is not a ply file\n";
  EXPECT_THROW(dw_viewer::loadXyz(garbage), dw::Error);
}

TEST(CloudInput, LasKeepsGeoreferencedPrecisionAndFiltersClasses) {
  const std::string path = std::string(DW_SHARED_DATA_DIR) + "/airborne/autzen_trim.las";
  if (!std::ifstream(path)) GTEST_SKIP() << "shared data not present: " << path;
  const auto all = dw_viewer::loadXyz(path);
  EXPECT_EQ(all.size(), 110000u);  // ../shared/data/README.md
  const auto ground = dw_viewer::loadXyz(path, 2);
  EXPECT_EQ(ground.size(), 26107u);
  double zmin = 1e300, zmax = -1e300;
  for (std::size_t i = 0; i < all.size(); ++i) {
    zmin = std::min(zmin, all.xyz[3 * i + 2]);
    zmax = std::max(zmax, all.xyz[3 * i + 2]);
  }
  EXPECT_GT(zmin, 400.0);  // README: z 406-521
  EXPECT_LT(zmax, 530.0);
  const auto mesh = dw_viewer::loadMesh(path, 2);
  EXPECT_EQ(mesh.numVertices(), 26107u);
  EXPECT_EQ(mesh.numTriangles(), 0u) << "a cloud: the viewer triangulates it";
}

// A LAZ tile (variable chunks) loads to exactly the points of its LAS twin, whole and by class.
TEST(CloudInput, LazLoadsAsItsLasTwin) {
  dw::las::LidarGenOptions o;
  o.num_points = 15000;
  o.seed = 4;
  const dw::las::LasHeader h = dw::las::syntheticHeader(o);
  const std::string las = tempPath("twin.las"), laz = tempPath("twin.laz");
  {
    dw::las::LasWriter a(las, h);
    dw::las::LazWriter b(laz, h, 0, 4000, dw::las::LazChunking::kVariable);
    std::size_t n = 0;
    dw::las::generateLidar(o, [&](const dw::las::LasRecord& r) {
      a.write(r);
      b.write(r);
      if (++n % 2500 == 0) b.endChunk();
    });
    a.close();
    b.close();
  }
  for (int cls : {-1, 2}) {
    const auto pa = dw_viewer::loadXyz(las, cls), pb = dw_viewer::loadXyz(laz, cls);
    ASSERT_GT(pa.size(), 0u);
    EXPECT_EQ(pa.xyz, pb.xyz) << cls;
    EXPECT_EQ(pa.input_index, pb.input_index) << cls;
  }
  std::remove(las.c_str());
  std::remove(laz.c_str());
}

TEST(CloudInput, MeshPolygonsAreFannedAndBadIndicesRejected) {
  const std::string path = tempPath("mesh.ply");
  std::ofstream(path)
      << "ply\nformat ascii 1.0\nelement vertex 5\nproperty double x\nproperty double y\n"
         "property double z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
         "0 0 0\n1 0 0\n1 1 1\n0 1 0\n2 2 2\n4 0 1 2 3\n3 1 4 2\n";
  const auto mesh = dw_viewer::loadMesh(path);
  EXPECT_EQ(mesh.numVertices(), 5u);
  ASSERT_EQ(mesh.numTriangles(), 3u) << "a quad is two triangles";
  EXPECT_EQ(mesh.triangles, (std::vector<std::uint32_t>{0, 1, 2, 0, 2, 3, 1, 4, 2}));

  const std::string bad = tempPath("bad_mesh.ply");
  std::ofstream(bad)
      << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
         "0 0 0\n1 0 0\n1 1 1\n3 0 1 7\n";
  EXPECT_THROW(dw_viewer::loadMesh(bad), dw::Error);
}

TEST(CloudInput, GeoreferencedCoordinatesGetAnOrigin) {
  const std::vector<double> local{0.1, 0.2, 0.3, 5.0, -4.0, 2.0};
  const auto o0 = dw_viewer::chooseOrigin(local);
  EXPECT_EQ(o0[0], 0.0);
  const std::vector<double> utm{500000.0, 5000000.0, 100.0, 500010.0, 5000020.0, 110.0};
  const auto o = dw_viewer::chooseOrigin(utm);
  EXPECT_EQ(o[0], 500005.0);
  EXPECT_EQ(o[1], 5000010.0);
  dw_viewer::XyzPoints pts;
  pts.xyz = {500000.125, 5000000.25, 100.5};
  const auto cloud = dw_viewer::toCloud(pts, o);
  EXPECT_EQ((*cloud)[0].x, -4.875f) << "millimetres survive the float conversion";
  EXPECT_EQ((*cloud)[0].y, -9.75f);
}

TEST(ColourMap, ScalesAreOrderedAndClamped) {
  const auto zero = dw_viewer::walkColour(0, 8), top = dw_viewer::walkColour(8, 8);
  EXPECT_GT(zero[2], zero[0]) << "short walks are blue";
  EXPECT_GT(top[0], top[2]) << "long walks are red";
  EXPECT_EQ(dw_viewer::walkColour(100, 8), top) << "beyond the scale: the last colour";
  EXPECT_NE(dw_viewer::walkColour(2, 8), dw_viewer::walkColour(3, 8));
  EXPECT_EQ(dw_viewer::heightColour(-1.0), dw_viewer::heightColour(0.0));
  EXPECT_EQ(dw_viewer::heightColour(2.0), dw_viewer::heightColour(1.0));
  std::vector<double> v;
  for (int i = 0; i < 1000; ++i) v.push_back(i);
  v.push_back(1e9);  // one outlier must not flatten the scale
  const auto r = dw_viewer::quantileRange(v);
  EXPECT_LT(r[1], 1000.0);
  EXPECT_GE(r[0], 0.0);
  const auto flat = dw_viewer::quantileRange({5.0, 5.0});
  EXPECT_GT(flat[1], flat[0]);
}

TEST(SceneGeometry, SegmentsAndPolyData) {
  pcl::PointCloud<pcl::PointXYZ> src, tgt;
  for (int i = 0; i < 10; ++i) {
    src.push_back(pcl::PointXYZ(float(i), 0, 0));
    tgt.push_back(pcl::PointXYZ(float(i), 1, 0));
  }
  pcl::Correspondences corr;
  for (int i = 0; i < 10; ++i) corr.emplace_back(i, 9 - i, 1.f);
  const auto all = dw_viewer::correspondenceSegments(src, tgt, corr, 100);
  ASSERT_EQ(all.size(), 60u);
  EXPECT_EQ(all[3], 9.f) << "line from source 0 to target 9";
  EXPECT_EQ(dw_viewer::correspondenceSegments(src, tgt, corr, 4).size(), 6u * 4) << "every 3rd of 10";
  const auto lines = dw_viewer::makeLines(all);
  EXPECT_EQ(lines->GetNumberOfLines(), 10);
  EXPECT_EQ(lines->GetNumberOfPoints(), 20);
  const auto pts = dw_viewer::makePoints({0, 0, 0, 1, 1, 1}, {{{255, 0, 0}}, {{0, 0, 255}}});
  EXPECT_EQ(pts->GetNumberOfVerts(), 2);
  ASSERT_NE(pts->GetPointData()->GetScalars(), nullptr);
  const auto mesh = dw_viewer::makeColouredMesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 1, 2},
                                                {{{1, 2, 3}}, {{4, 5, 6}}, {{7, 8, 9}}});
  EXPECT_EQ(mesh->GetNumberOfPolys(), 1);
}

}  // namespace
