// bench_gpu_localize: per-frame latency of dw::gpu::Localizer beside dw::Localizer (all host threads)
// on the same map graph and scans, full resolution, point-to-point. Prints the median and p95 per
// frame of each, their ratio, the largest pose difference between them, and where the GPU frame's
// time goes: the host's finite filter (voxelDownsample at 0), the source set-up (finite filter,
// centring, Morton order: IterativeClosestPoint::setInputSource) and align (staging, upload, the
// device loop, the read-back), each timed alone on a second ICP that shares the uploaded map.
//   bench_gpu_localize [FRAMES=40] [RADIUS_M=8]
//       the localizer tests' sequence: the dragon as a 20 m scene, scans within RADIUS_M of the sensor
//   bench_gpu_localize --street MAP_POINTS SCAN_POINTS [FRAMES=20]
//       the generated street of bench/dw_localize_bench.cpp (400 x 400 m), scans of SCAN_POINTS
//       within 60 m of a sensor moving 1 m per frame; 1 m correspondence distance, 30 iterations
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "../../bench/synthetic_street.h"
#include "../../test/core/registration/sequence.h"
#include "pcl_delaunay_walk/core/registration/localizer.h"
#include "pcl_delaunay_walk/core/registration/voxel_downsample.h"
#include "pcl_delaunay_walk/gpu/localizer.h"

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(q * double(v.size())))];
}

struct Sequence {
  std::string name;
  std::vector<float> map;
  std::vector<std::vector<float>> scans;
  std::vector<Eigen::Matrix4d> truth;
  dw::LocalizerOptions options;
};

Sequence dragon(std::size_t frames, double radius) {
  Sequence s;
  s.map = dw_test::dragonScene();
  s.truth = dw_test::arcTrajectory(frames);
  for (std::size_t k = 0; k < frames; ++k)
    s.scans.push_back(dw_test::cutScan(s.map, s.truth[k], radius, unsigned(k + 1)));
  s.options.icp.max_correspondence_distance = 0.5;
  s.options.icp.max_iterations = 50;
  char name[64];
  std::snprintf(name, sizeof name, "dragon scene, radius %.1f m", radius);
  s.name = name;
  return s;
}

Sequence street(std::size_t map_points, std::size_t scan_points, std::size_t frames) {
  Sequence s;
  s.map = dw_bench::syntheticStreet(map_points, 1);
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  pose(0, 3) = -60, pose(2, 3) = 1.8;
  Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
  step.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  step(0, 3) = 1.0;
  for (std::size_t k = 0; k < frames; ++k) {
    s.truth.push_back(pose);
    s.scans.push_back(dw_bench::cutStreetScan(s.map, pose, 60.0, scan_points, 1 + unsigned(k)));
    pose = pose * step;
  }
  s.name = "street, 60 m scans";
  return s;
}

/// The GPU frame's parts, timed alone per scan (medians printed).
void profileHostParts(const Sequence& s, const dw::gpu::Localizer& gpu) {
  dw::gpu::IterativeClosestPoint icp(gpu.deviceMap());
  icp.setParameters(dw::gpu::icpParametersFor(gpu.options().icp));
  icp.setWarmStart(true);
  std::vector<double> filter, setup, align;
  for (std::size_t k = 0; k < s.scans.size(); ++k) {
    const auto& scan = s.scans[k];
    auto t = Clock::now();
    const std::vector<float> pts =
        dw::voxelDownsample(dw::PointView::fromFloat(scan.data(), scan.size() / 3), 0.0);
    filter.push_back(msSince(t));
    t = Clock::now();
    icp.setInputSource(dw::PointView::fromFloat(pts.data(), pts.size() / 3));
    setup.push_back(msSince(t));
    dw::gpu::Matrix4d guess;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) guess[std::size_t(4 * r + c)] = s.truth[k](r, c);
    t = Clock::now();
    icp.align(guess);
    align.push_back(msSince(t));
  }
  std::printf("gpu parts p50 ms: finite filter %.3f, setInputSource %.3f, align %.3f (guess = truth)\n",
              percentile(filter, 0.5), percentile(setup, 0.5), percentile(align, 0.5));
}

int run(const Sequence& s) {
  const std::size_t frames = s.scans.size();
  auto t = Clock::now();
  dw::Localizer cpu(dw::PointView::fromFloat(s.map.data(), s.map.size() / 3), s.options);
  const double build_ms = msSince(t);
  t = Clock::now();
  dw::gpu::Localizer gpu(cpu.graph(), s.options);
  const double upload_ms = msSince(t);
  std::size_t points = 0;
  for (const auto& scan : s.scans) points += scan.size() / 3;
  std::vector<double> tc, tg;
  double worst = 0;
  int ok_c = 0, ok_g = 0, it_c = 0, it_g = 0;
  cpu.setPose(s.truth[0]);
  gpu.setPose(s.truth[0]);
  for (const auto& scan : s.scans) {
    const dw::PointView v = dw::PointView::fromFloat(scan.data(), scan.size() / 3);
    const dw::FrameResult a = cpu.registerScan(v), b = gpu.registerScan(v);
    tc.push_back(a.latency_seconds * 1e3);
    tg.push_back(b.latency_seconds * 1e3);
    worst = std::max(worst, (a.pose - b.pose).cwiseAbs().maxCoeff());
    ok_c += a.status == dw::FrameStatus::Ok, ok_g += b.status == dw::FrameStatus::Ok;
    it_c += a.iterations, it_g += b.iterations;
  }
  std::printf("%s: map %zu points (graph %.0f ms, upload %.0f ms), %zu frames, %.0f points per scan\n",
              s.name.c_str(), cpu.mapPoints(), build_ms, upload_ms, frames, double(points) / double(frames));
  std::printf("cpu  ms/frame p50 %.3f p95 %.3f  ok %d/%zu  iterations %d\n", percentile(tc, 0.5),
              percentile(tc, 0.95), ok_c, frames, it_c);
  std::printf("gpu  ms/frame p50 %.3f p95 %.3f  ok %d/%zu  iterations %d\n", percentile(tg, 0.5),
              percentile(tg, 0.95), ok_g, frames, it_g);
  std::printf("cpu/gpu p50 ratio %.2f  max |pose diff| %.2e\n", percentile(tc, 0.5) / percentile(tg, 0.5),
              worst);
  profileHostParts(s, gpu);
  return worst <= 1e-5 && ok_c == ok_g ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (dw::gpu::cudaDeviceCount() == 0) {
      std::fprintf(stderr, "bench_gpu_localize: no CUDA device\n");
      return 2;
    }
    if (argc > 1 && std::strcmp(argv[1], "--street") == 0) {
      if (argc < 4) {
        std::fprintf(stderr, "usage: bench_gpu_localize --street MAP_POINTS SCAN_POINTS [FRAMES=20]\n");
        return 2;
      }
      const auto frames = argc > 4 ? std::size_t(std::atol(argv[4])) : std::size_t(20);
      return run(street(std::size_t(std::atol(argv[2])), std::size_t(std::atol(argv[3])), frames));
    }
    const std::size_t frames = argc > 1 ? std::size_t(std::atoi(argv[1])) : 40;
    const double radius = argc > 2 ? std::atof(argv[2]) : 8.0;
    return run(dragon(frames, radius));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_gpu_localize: %s\n", e.what());
    return 1;
  }
}
