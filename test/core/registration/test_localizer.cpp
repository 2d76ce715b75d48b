// The localizer: tracks a known trajectory through a real cloud, gives a status for every bad frame,
// saves and loads its map (refusing corrupt and other-version files), and its helpers (voxel grid,
// KITTI pose files) behave.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <limits>

#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/core/registration/kitti_poses.h"
#include "pcl_delaunay_walk/core/registration/localizer.h"
#include "pcl_delaunay_walk/core/registration/voxel_downsample.h"
#include "sequence.h"

namespace {

std::string tempPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/test_core_registration_" + name;
}

dw::LocalizerOptions sceneOptions() {
  dw::LocalizerOptions o;
  o.num_threads = 2;
  o.icp.max_correspondence_distance = 0.5;
  o.icp.max_iterations = 50;
  return o;
}

/// Runs the localizer over the sequence; returns the worst translation and rotation errors.
std::pair<double, double> track(dw::Localizer& loc, const std::vector<float>& scene,
                                const std::vector<Eigen::Matrix4d>& truth) {
  double worst_t = 0, worst_r = 0;
  loc.setPose(truth[0]);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const std::vector<float> scan = dw_test::cutScan(scene, truth[k], 8.0, unsigned(k + 1));
    const dw::FrameResult r = loc.registerScan(dw::PointView::fromFloat(scan.data(), scan.size() / 3));
    EXPECT_EQ(r.status, dw::FrameStatus::Ok) << "frame " << k;
    EXPECT_GT(r.fitness, 0.9) << "frame " << k;
    worst_t = std::max(worst_t, dw_test::translationError(r.pose, truth[k]));
    worst_r = std::max(worst_r, dw_test::rotationError(r.pose, truth[k]));
  }
  return {worst_t, worst_r};
}

TEST(Localizer, TracksAKnownTrajectoryThroughARealCloud) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto truth = dw_test::arcTrajectory(20);
  for (dw::IcpMetric metric : {dw::IcpMetric::PointToPoint, dw::IcpMetric::PointToPlane}) {
    dw::LocalizerOptions o = sceneOptions();
    o.icp.metric = metric;
    dw::Localizer loc(dw::PointView::fromFloat(scene.data(), scene.size() / 3), o);
    const auto [t, r] = track(loc, scene, truth);
    // 5 mm noise on a 20 m scene: the poses stay within a few centimetres and a few milliradians.
    EXPECT_LT(t, 0.03) << int(metric);
    EXPECT_LT(r, 3e-3) << int(metric);
  }
}

TEST(Localizer, DownsampledScansTrackToo) {
  const std::vector<float> scene = dw_test::dragonScene();
  dw::LocalizerOptions o = sceneOptions();
  o.voxel = 0.3;
  dw::Localizer loc(dw::PointView::fromFloat(scene.data(), scene.size() / 3), o);
  const auto [t, r] = track(loc, scene, dw_test::arcTrajectory(10));
  EXPECT_LT(t, 0.05);
  EXPECT_LT(r, 5e-3);
}

TEST(Localizer, BadFramesGetStatusesAndNeverThrow) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto truth = dw_test::arcTrajectory(3);
  dw::Localizer loc(dw::PointView::fromFloat(scene.data(), scene.size() / 3), sceneOptions());
  loc.setPose(truth[0]);
  const std::vector<float> none;
  EXPECT_EQ(loc.registerScan(dw::PointView::fromFloat(none.data(), 0)).status, dw::FrameStatus::EmptyScan);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> nans(300, nan);
  EXPECT_EQ(loc.registerScan(dw::PointView::fromFloat(nans.data(), 100)).status,
            dw::FrameStatus::NoFinitePoints);
  // Far outside the map: nothing within the correspondence distance.
  std::vector<float> far = dw_test::cutScan(scene, truth[0], 8.0, 1);
  for (std::size_t i = 0; i < far.size(); i += 3) far[i] += 1000.f;
  dw::FrameResult r = loc.registerScan(dw::PointView::fromFloat(far.data(), far.size() / 3));
  EXPECT_EQ(r.status, dw::FrameStatus::NoCorrespondences);
  EXPECT_EQ(r.pose, truth[0]);  // the track coasts on its (still motionless) prediction
  // Mostly clutter: registered, but most points have no map point near: lost track.
  std::vector<float> clutter = dw_test::cutScan(scene, truth[0], 8.0, 2, 0.2);
  const std::size_t real = clutter.size() / 3;
  for (std::size_t i = 0; i < 4 * real; ++i)
    clutter.insert(clutter.end(), {30.f + float(i % 17), 30.f, 30.f});
  r = loc.registerScan(dw::PointView::fromFloat(clutter.data(), clutter.size() / 3));
  EXPECT_EQ(r.status, dw::FrameStatus::LostTrack);
  EXPECT_LT(r.fitness, 0.3);
  // And the track picks up again on a good frame.
  const std::vector<float> good = dw_test::cutScan(scene, truth[0], 8.0, 3);
  r = loc.registerScan(dw::PointView::fromFloat(good.data(), good.size() / 3));
  EXPECT_EQ(r.status, dw::FrameStatus::Ok);
  EXPECT_LT(dw_test::translationError(r.pose, truth[0]), 0.03);
}

TEST(Localizer, EmptyMapGivesNoCorrespondences) {
  const std::vector<float> none;
  dw::Localizer loc(dw::PointView::fromFloat(none.data(), 0), sceneOptions());
  const std::vector<float> scan = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  EXPECT_EQ(loc.registerScan(dw::PointView::fromFloat(scan.data(), 3)).status,
            dw::FrameStatus::NoCorrespondences);
}

TEST(Localizer, SavedMapLoadsAndTracksTheSame) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto truth = dw_test::arcTrajectory(5);
  dw::Localizer built(dw::PointView::fromFloat(scene.data(), scene.size() / 3), sceneOptions());
  const std::string path = tempPath("map.graph");
  built.save(path);
  dw::Localizer loaded = dw::Localizer::load(path, sceneOptions());
  EXPECT_EQ(loaded.mapPoints(), built.mapPoints());
  EXPECT_EQ(loaded.graph().numDirectedEdges(), built.graph().numDirectedEdges());
  EXPECT_TRUE(loaded.graph().isMapped());  // the records are the file's mapping, not a copy
  ASSERT_EQ(0, std::remove(path.c_str()));  // the mapping outlives the path
  built.setPose(truth[0]);
  loaded.setPose(truth[0]);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const std::vector<float> scan = dw_test::cutScan(scene, truth[k], 8.0, unsigned(k + 7));
    const dw::PointView v = dw::PointView::fromFloat(scan.data(), scan.size() / 3);
    const dw::FrameResult a = built.registerScan(v), b = loaded.registerScan(v);
    // The loaded map's points are origin + local rounded to float: equal to ~1e-7 relative.
    EXPECT_LT((a.pose - b.pose).cwiseAbs().maxCoeff(), 1e-5) << "frame " << k;
  }
}

TEST(Localizer, CorruptOrOtherVersionMapFilesAreRefused) {
  const std::vector<float> scene = dw_test::dragonScene();
  dw::Localizer loc(dw::PointView::fromFloat(scene.data(), 3000), sceneOptions());
  std::vector<std::uint8_t> bytes = dw::serializeGraph(loc.graph());
  const std::string path = tempPath("bad.graph");
  auto write = [&](const std::vector<std::uint8_t>& b) {
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
  };
  auto message = [&]() -> std::string {
    try {
      dw::Localizer::load(path);
    } catch (const dw::GraphFileError& e) {
      return e.what();
    }
    return "loaded";
  };
  std::vector<std::uint8_t> flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x40;
  write(flipped);
  EXPECT_NE(message().find("refused"), std::string::npos) << message();
  std::vector<std::uint8_t> other = bytes;
  other[8] = 99;  // the version field follows the 8-byte magic
  dw::resealGraphFile(other);
  write(other);
  EXPECT_NE(message().find("version"), std::string::npos) << message();
  write(std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 50));
  EXPECT_NE(message().find(path), std::string::npos);
  std::remove(path.c_str());
  EXPECT_THROW(dw::Localizer::load(tempPath("missing.graph")), dw::Error);
}

// The frame bracket both localizers run: what reaches the ICP call, what never does, and how its
// result becomes the frame's fields, status and the next prediction.
TEST(FrameTrack, RegisterFrameCallsTheIcpOnlyForARegistrableScan) {
  dw::FrameTrack track;
  dw::FrameRules rules;
  rules.min_fitness = 0.5;
  int calls = 0;
  Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
  step(0, 3) = 0.25;
  dw::IcpResult answer;
  answer.iterations = 7;
  answer.convergence = dw::IcpConvergence::Transform;
  answer.correspondences = 2;
  answer.mse = 0.04;
  const dw::FrameIcp icp = [&](const std::vector<float>& pts, const Eigen::Matrix4d& guess) {
    ++calls;
    EXPECT_EQ(pts.size(), 9u);  // the NaN point is gone
    dw::IcpResult r = answer;
    r.transform = guess * step;
    return r;
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> scan = {0, 0, 0, 1, 0, 0, nan, 0, 0, 0, 1, 0};
  const std::vector<float> all_nan = {nan, 0, 0, 0, nan, 0};
  EXPECT_EQ(track.registerFrame(dw::PointView::fromFloat(scan.data(), 0), rules, icp).status,
            dw::FrameStatus::EmptyScan);
  EXPECT_EQ(track.registerFrame(dw::PointView::fromFloat(all_nan.data(), 2), rules, icp).status,
            dw::FrameStatus::NoFinitePoints);
  EXPECT_EQ(calls, 0);
  dw::FrameResult r = track.registerFrame(dw::PointView::fromFloat(scan.data(), 4), rules, icp);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(r.status, dw::FrameStatus::Ok);  // fitness 2/3 >= 0.5
  EXPECT_EQ(r.points, 3u);
  EXPECT_EQ(r.iterations, 7);
  EXPECT_EQ(r.convergence, dw::IcpConvergence::Transform);
  EXPECT_DOUBLE_EQ(r.fitness, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(r.rmse, 0.2);
  EXPECT_TRUE(r.pose.isApprox(step, 0.0));
  EXPECT_TRUE(track.predictedPose(true).isApprox(step * step, 0.0));  // constant velocity
  answer.correspondences = 1;  // fitness 1/3: lost, the track coasts on the prediction
  r = track.registerFrame(dw::PointView::fromFloat(scan.data(), 4), rules, icp);
  EXPECT_EQ(r.status, dw::FrameStatus::LostTrack);
  EXPECT_TRUE(r.pose.isApprox(step * step, 0.0));
  Eigen::Matrix4d bad = Eigen::Matrix4d::Identity();
  bad(1, 3) = std::numeric_limits<double>::quiet_NaN();
  track.setPose(bad);  // a guess no ICP can start from: no call, no correspondences
  r = track.registerFrame(dw::PointView::fromFloat(scan.data(), 4), rules, icp);
  EXPECT_EQ(calls, 2);
  EXPECT_EQ(r.status, dw::FrameStatus::NoCorrespondences);
  EXPECT_EQ(r.convergence, dw::IcpConvergence::NoCorrespondences);
  EXPECT_GT(r.latency_seconds, 0.0);
}

TEST(VoxelDownsample, OneCentroidPerOccupiedVoxelInKeyOrder) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> pts = {0.1f, 0.1f, 0.1f, 0.3f, 0.3f,  0.3f, 1.5f, 0.2f,
                                  0.2f, nan,  0,    0,    -0.5f, 0,    0};
  const std::vector<float> out = dw::voxelDownsample(dw::PointView::fromFloat(pts.data(), 5), 1.0);
  ASSERT_EQ(out.size(), 9u);
  EXPECT_FLOAT_EQ(out[0], -0.5f);  // voxel x = -1 first
  EXPECT_FLOAT_EQ(out[3], 0.2f);   // the two points of voxel (0, 0, 0) averaged
  EXPECT_FLOAT_EQ(out[6], 1.5f);
  EXPECT_EQ(dw::voxelDownsample(dw::PointView::fromFloat(pts.data(), 5), 0).size(), 12u);  // finite ones
  // A stray point whose voxel index would overflow is dropped, never an error.
  const std::vector<float> stray = {1e30f, 0, 0, 0.5f, 0.5f, 0.5f};
  const std::vector<float> kept = dw::voxelDownsample(dw::PointView::fromFloat(stray.data(), 2), 1e-12);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_FLOAT_EQ(kept[0], 0.5f);
}

TEST(VoxelDownsample, FullResolutionKeepsTheFinitePointsOfAnyView) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  // x, y, z, intensity: a strided float view, as PCL's PointXYZI lays it out.
  const std::vector<float> xyzi = {1.25f, -2.5f, 3.0f, 9, nan, 0, 0, 9, 0, inf, 0, 9, -0.125f, 7.5f, 1e-30f, 9};
  const std::vector<float> want = {1.25f, -2.5f, 3.0f, -0.125f, 7.5f, 1e-30f};
  EXPECT_EQ(dw::voxelDownsample(dw::PointView::fromFloat(xyzi.data(), 4, 4 * sizeof(float)), 0), want);
  std::vector<double> xyz;
  for (std::size_t i = 0; i < 4; ++i)
    for (int c = 0; c < 3; ++c) xyz.push_back(double(xyzi[4 * i + std::size_t(c)]));
  EXPECT_EQ(dw::voxelDownsample(dw::PointView::fromDouble(xyz.data(), 4), 0), want);
}

TEST(KittiPoses, RoundTripAndErrorsNameTheLine) {
  const auto poses = dw_test::arcTrajectory(4);
  const std::string path = tempPath("poses.txt");
  dw::writeKittiPoses(path, poses);
  const auto back = dw::readKittiPoses(path);
  ASSERT_EQ(back.size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) EXPECT_EQ(back[i], poses[i]);
  std::ofstream(path) << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n";
  try {
    dw::readKittiPoses(path);
    ADD_FAILURE() << "read a short line";
  } catch (const dw::Error& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "2 0 0 0 0 1 0 0 0 0 1 0\n";
  EXPECT_THROW(dw::readKittiPoses(path), dw::Error);  // not a rotation
  // A failed write leaves the existing file as it was.
  EXPECT_THROW(dw::writeKittiPoses(tempPath("no_such_dir/poses.txt"), poses), dw::Error);
  std::remove(path.c_str());
}

}  // namespace
