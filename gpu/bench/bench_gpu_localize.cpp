// bench_gpu_localize: per-frame latency of dw::gpu::Localizer beside dw::Localizer (all host threads)
// on the same map graph and scans: the localizer tests' sequence (the dragon as a 20 m scene, scans
// within a radius of the sensor along an arc), full resolution, point-to-point. Prints the median and
// p95 per frame of each, their ratio and the largest pose difference between them.
//   usage: bench_gpu_localize [FRAMES=40] [RADIUS_M=8]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "../../test/core/registration/sequence.h"
#include "pcl_delaunay_walk/core/registration/localizer.h"
#include "pcl_delaunay_walk/gpu/localizer.h"

namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(q * double(v.size())))];
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::size_t frames = argc > 1 ? std::size_t(std::atoi(argv[1])) : 40;
    const double radius = argc > 2 ? std::atof(argv[2]) : 8.0;
    if (dw::gpu::cudaDeviceCount() == 0) {
      std::fprintf(stderr, "bench_gpu_localize: no CUDA device\n");
      return 2;
    }
    const std::vector<float> scene = dw_test::dragonScene();
    const auto truth = dw_test::arcTrajectory(frames);
    dw::LocalizerOptions o;
    o.icp.max_correspondence_distance = 0.5;
    o.icp.max_iterations = 50;
    dw::Localizer cpu(dw::PointView::fromFloat(scene.data(), scene.size() / 3), o);
    dw::gpu::Localizer gpu(cpu.graph(), o);
    std::vector<std::vector<float>> scans;
    std::size_t points = 0;
    for (std::size_t k = 0; k < frames; ++k) {
      scans.push_back(dw_test::cutScan(scene, truth[k], radius, unsigned(k + 1)));
      points += scans.back().size() / 3;
    }
    std::vector<double> tc, tg;
    double worst = 0;
    int ok_c = 0, ok_g = 0, it_c = 0, it_g = 0;
    cpu.setPose(truth[0]);
    gpu.setPose(truth[0]);
    for (const auto& s : scans) {
      const dw::PointView v = dw::PointView::fromFloat(s.data(), s.size() / 3);
      const dw::FrameResult a = cpu.registerScan(v), b = gpu.registerScan(v);
      tc.push_back(a.latency_seconds * 1e3);
      tg.push_back(b.latency_seconds * 1e3);
      worst = std::max(worst, (a.pose - b.pose).cwiseAbs().maxCoeff());
      ok_c += a.status == dw::FrameStatus::Ok, ok_g += b.status == dw::FrameStatus::Ok;
      it_c += a.iterations, it_g += b.iterations;
    }
    std::printf("map %zu points, %zu frames, %.0f points per scan (radius %.1f m)\n", cpu.mapPoints(), frames,
                double(points) / double(frames), radius);
    std::printf("cpu  ms/frame p50 %.3f p95 %.3f  ok %d/%zu  iterations %d\n", percentile(tc, 0.5),
                percentile(tc, 0.95), ok_c, frames, it_c);
    std::printf("gpu  ms/frame p50 %.3f p95 %.3f  ok %d/%zu  iterations %d\n", percentile(tg, 0.5),
                percentile(tg, 0.95), ok_g, frames, it_g);
    std::printf("cpu/gpu p50 ratio %.2f  max |pose diff| %.2e\n", percentile(tc, 0.5) / percentile(tg, 0.5),
                worst);
    return worst <= 1e-5 && ok_c == ok_g ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_gpu_localize: %s\n", e.what());
    return 1;
  }
}
