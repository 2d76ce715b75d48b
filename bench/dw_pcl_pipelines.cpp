/// \file dw_pcl_pipelines.cpp
/// \brief dw_pcl_pipelines: PCL's own algorithms end to end with pcl::search::DelaunayWalk against
/// pcl::search::KdTree (FLANN), in one process: NormalEstimationOMP (k nearest, the reference's own
/// points: self-kNN) and EuclideanClusterExtraction (radius search over the cloud's own points). Each
/// search is timed with its build inside (a fresh search object, as a user calls compute() on a new
/// cloud) and without it (the walk: a search whose graph was built before; the tree: minus its build
/// time measured alone, since FLANN rebuilds on every setInputCloud). CSV into --out, a table on stdout.
///   dw_pcl_pipelines [--datasets dragon-100k,lidar-69k,kitti] [--threads 1,2] [--k 16] [--repeats 2]
///                    [--out DIR]
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"  // Eigen inside PCL's templates (see dw_bench.cpp)
#endif

#include <pcl/features/normal_3d_omp.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>

#include "common/datasets.h"
#include "common/nn_method.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"

namespace {

using PointT = pcl::PointXYZ;
using Cloud = pcl::PointCloud<PointT>;

struct Options {
  std::vector<std::string> datasets{"dragon-100k", "lidar-69k", "kitti"};
  std::vector<unsigned> threads{1, 2};
  int k = 16, repeats = 2;
  std::string out = "bench/results/pipelines";
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout
          << "usage: dw_pcl_pipelines [--datasets dragon-100k,lidar-69k,kitti] [--threads 1,2] [--k 16]\n"
             "                        [--repeats 2] [--out DIR]\n";
      std::exit(0);
    }
    if (a.rfind("--", 0) != 0 || i + 1 >= argc)
      throw dw::Error("dw_pcl_pipelines: bad argument '" + a + "' (see --help)");
    const std::string key = a.substr(2), v = argv[++i];
    try {
      if (key == "datasets")
        o.datasets = split(v);
      else if (key == "threads") {
        o.threads.clear();
        for (const auto& t : split(v)) o.threads.push_back(static_cast<unsigned>(std::stoul(t)));
      } else if (key == "k")
        o.k = std::stoi(v);
      else if (key == "repeats")
        o.repeats = std::stoi(v);
      else if (key == "out")
        o.out = v;
      else
        throw dw::Error("dw_pcl_pipelines: unknown option --" + key);
    } catch (const std::invalid_argument&) {
      throw dw::Error("dw_pcl_pipelines: --" + key + " needs a number, got '" + v + "'");
    }
  }
  if (o.k < 3 || o.repeats < 1 || o.threads.empty())
    throw dw::Error("dw_pcl_pipelines: --k must be >= 3, --repeats >= 1");
  return o;
}

/// A data set by name: dw_bench's (dwb::loadDataset), or "kitti" (the first KITTI frame, no-return
/// points at the origin dropped).
Cloud::Ptr load(const std::string& name) {
  std::vector<float> xyz;
  if (name == "kitti") {
    const std::vector<float> all = dwb::loadFiniteXyz(dwb::findDataFile("scans", "kitti_000000.bin"));
    for (std::size_t i = 0; i + 2 < all.size(); i += 3)
      if (all[i] != 0.f || all[i + 1] != 0.f || all[i + 2] != 0.f)
        xyz.insert(xyz.end(), &all[i], &all[i] + 3);
  } else {
    xyz = dwb::loadDataset(name).xyz;
  }
  return dwb::toCloud(xyz);
}

/// Minimum wall time of `repeats` calls.
double best(int repeats, const std::function<void()>& f) {
  double b = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = dwb::Clock::now();
    f();
    b = std::min(b, dwb::secondsSince(t0));
  }
  return b;
}

pcl::search::Search<PointT>::Ptr makeSearch(const std::string& which, unsigned threads) {
  if (which == "kdtree") return std::make_shared<pcl::search::KdTree<PointT>>(false);
  auto w = std::make_shared<pcl::search::DelaunayWalk<PointT>>(false);
  dw::BuildOptions bo;
  bo.num_threads = threads;
  w->setBuildOptions(bo);
  return w;
}

/// Mean distance to the nearest other point (a KdTree over at most 20k evenly strided points' queries).
double meanSpacing(const Cloud::Ptr& cloud) {
  pcl::search::KdTree<PointT> tree;
  tree.setInputCloud(cloud);
  pcl::Indices idx;
  std::vector<float> d2;
  const std::size_t step = std::max<std::size_t>(1, cloud->size() / 20000);
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < cloud->size(); i += step)
    if (tree.nearestKSearch((*cloud)[i], 2, idx, d2) == 2) sum += std::sqrt(double(d2[1])), ++n;
  return n ? sum / double(n) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::cout << std::unitbuf;
    const Options o = parse(argc, argv);
    if (std::system(("mkdir -p '" + o.out + "'").c_str()) != 0)
      throw dw::Error("dw_pcl_pipelines: cannot create " + o.out);
    std::ofstream csv(o.out + "/pipelines.csv");
    if (!csv) throw dw::Error("dw_pcl_pipelines: cannot write " + o.out + "/pipelines.csv");
    csv << "dataset,points,algorithm,parameter,search,threads,seconds_incl_build,build_seconds,seconds_excl_"
           "build,"
           "result\n";
    std::printf(
        "| data set | algorithm | threads | KdTree incl. / excl. build | DelaunayWalk incl. / excl. build | "
        "walk / KdTree incl. | excl. |\n|---|---|---|---|---|---|---|\n");
    for (const auto& name : o.datasets) {
      const Cloud::Ptr cloud = load(name);
      const double spacing = meanSpacing(cloud), tolerance = 2.5 * spacing;
      std::cerr << "== " << name << ": " << cloud->size() << " points, mean spacing " << spacing << "\n";
      for (unsigned t : o.threads) {
        for (const std::string algo : {"normals", "clusters"}) {
          double incl[2] = {0, 0}, build[2] = {0, 0}, excl[2] = {0, 0};
          std::size_t result[2] = {0, 0};
          const char* searches[2] = {"kdtree", "delaunay-walk"};
          for (int s = 0; s < 2; ++s) {
            // The algorithm on a given search object; returns a checksum-like result count.
            auto run = [&](const pcl::search::Search<PointT>::Ptr& search) -> std::size_t {
              if (algo == "normals") {
                pcl::NormalEstimationOMP<PointT, pcl::Normal> ne(t);
                ne.setInputCloud(cloud);
                ne.setSearchMethod(search);
                ne.setKSearch(o.k);
                pcl::PointCloud<pcl::Normal> normals;
                ne.compute(normals);
                std::size_t finite = 0;
                for (const auto& n : normals) finite += std::isfinite(n.normal_x) ? 1 : 0;
                return finite;
              }
              pcl::EuclideanClusterExtraction<PointT> ec;
              ec.setClusterTolerance(tolerance);
              ec.setMinClusterSize(1);
              ec.setSearchMethod(search);
              ec.setInputCloud(cloud);
              std::vector<pcl::PointIndices> clusters;
              ec.extract(clusters);
              return clusters.size();
            };
            incl[s] = best(o.repeats, [&] { result[s] = run(makeSearch(searches[s], t)); });
            build[s] = best(o.repeats, [&] { makeSearch(searches[s], t)->setInputCloud(cloud); });
            if (s == 1) {
              auto walk = makeSearch(searches[s], t);
              walk->setInputCloud(cloud);  // built once; compute() finds the content unchanged
              excl[s] = best(o.repeats, [&] { run(walk); });
            } else {
              excl[s] = std::max(0.0, incl[s] - build[s]);
            }
            csv << name << "," << cloud->size() << "," << algo << ","
                << (algo == "normals" ? "k=" + std::to_string(o.k) : "tolerance=" + std::to_string(tolerance))
                << "," << searches[s] << "," << t << "," << incl[s] << "," << build[s] << "," << excl[s]
                << "," << result[s] << "\n";
            csv.flush();
          }
          std::printf("| %s (%zu) | %s | %u | %.1f / %.1f ms | %.1f / %.1f ms | %.2fx | %.2fx |%s\n",
                      name.c_str(), cloud->size(),
                      algo == "normals" ? "NormalEstimationOMP k" : "EuclideanClusterExtraction", t,
                      incl[0] * 1e3, excl[0] * 1e3, incl[1] * 1e3, excl[1] * 1e3, incl[0] / incl[1],
                      excl[1] > 0 ? excl[0] / excl[1] : 0.0,
                      result[0] == result[1] ? "" : "  RESULTS DIFFER (finite normals / clusters)");
        }
      }
    }
    std::cout << "(walk / KdTree: the KdTree's time over the walk's, > 1 = the walk is faster)\nresults in "
              << o.out << "/\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "dw_pcl_pipelines: error: " << e.what() << "\n";
    return 1;
  }
}
