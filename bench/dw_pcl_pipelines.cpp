/// \file dw_pcl_pipelines.cpp
/// \brief dw_pcl_pipelines: PCL's own algorithms end to end with pcl::search::DelaunayWalk against
/// pcl::search::KdTree (FLANN) and a nanoflann adaptor (peers/pcl_nanoflann_search.h, nanoflann from
/// DW_PEERS_DIR), in one process, on the reference's own points:
///   normals   NormalEstimationOMP, k nearest (self-kNN)
///   clusters  EuclideanClusterExtraction, radius search (tolerance 2.5 x the mean spacing)
///   gicp-cov  GICP's covariances: for every point its --gicp-k (20, GICP's default) nearest, their
///             covariance, its SVD with the smallest singular value replaced by GICP's epsilon; the loop
///             of pcl::GeneralizedIterativeClosestPoint::computeCovariances over any pcl::search::Search
///             (PCL 1.13 types that function's tree as a KdTree), checked against PCL's own function
///             on the KdTree, which is timed beside it ("pcl-gicp-stock")
/// Each search is timed with its build inside (a fresh search object, as a user calls compute() on a new
/// cloud) and without it (the walk: a search whose graph was built before, which compute() keeps while
/// the content is unchanged; the trees, which rebuild on every setInputCloud: minus their build time
/// measured alone). One thread: process CPU time; more: wall clock. CSV into --out, a table on stdout.
///   dw_pcl_pipelines [--datasets dragon-100k,lidar-69k,kitti] [--threads 1,2] [--k 16] [--gicp-k 20]
///                    [--algorithms normals,clusters,gicp-cov] [--repeats 2] [--out DIR]
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"  // Eigen inside PCL's templates (see dw_bench.cpp)
#endif

#include <pcl/features/normal_3d_omp.h>
#include <pcl/registration/gicp.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <numeric>
#include <sstream>

#include "common/datasets.h"
#include "common/nn_method.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"
#ifdef DW_HAVE_PEER_NANOFLANN
#include "peers/pcl_nanoflann_search.h"
#endif

namespace {

using PointT = pcl::PointXYZ;
using Cloud = pcl::PointCloud<PointT>;

struct Options {
  std::vector<std::string> datasets{"dragon-100k", "lidar-69k", "kitti"};
  std::vector<unsigned> threads{1, 2};
  std::vector<std::string> algorithms{"normals", "clusters", "gicp-cov"};
  int k = 16, gicp_k = 20, repeats = 2;
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
             "                        [--gicp-k 20] [--algorithms normals,clusters,gicp-cov] [--repeats 2]\n"
             "                        [--out DIR]\n";
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
      else if (key == "gicp-k")
        o.gicp_k = std::stoi(v);
      else if (key == "algorithms")
        o.algorithms = split(v);
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
  if (o.k < 3 || o.gicp_k < 3 || o.repeats < 1 || o.threads.empty())
    throw dw::Error("dw_pcl_pipelines: --k and --gicp-k must be >= 3, --repeats >= 1");
  for (const auto& a : o.algorithms)
    if (a != "normals" && a != "clusters" && a != "gicp-cov")
      throw dw::Error("dw_pcl_pipelines: unknown algorithm '" + a + "' (normals, clusters, gicp-cov)");
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

/// Best of `repeats` calls: process CPU time on one thread (steadier on a shared machine), wall clock
/// on more.
double best(int repeats, unsigned threads, const std::function<void()>& f) {
  double b = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = dwb::Clock::now();
    const double c0 = dwb::processCpuSeconds();
    f();
    b = std::min(b, threads == 1 ? dwb::processCpuSeconds() - c0 : dwb::secondsSince(t0));
  }
  return b;
}

/// The searches compared, in report order: the first is the reference of the result checks.
std::vector<std::string> searchNames() {
  std::vector<std::string> s{"kdtree"};
#ifdef DW_HAVE_PEER_NANOFLANN
  s.push_back("nanoflann-" NANOFLANN_VERSION_STRING);
#endif
  s.push_back("delaunay-walk");
  return s;
}

pcl::search::Search<PointT>::Ptr makeSearch(const std::string& which, unsigned threads) {
  if (which == "kdtree") return std::make_shared<pcl::search::KdTree<PointT>>(false);
#ifdef DW_HAVE_PEER_NANOFLANN
  if (which.rfind("nanoflann", 0) == 0) return std::make_shared<dwb::NanoflannSearch<PointT>>(false);
#endif
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

using Covariances = pcl::GeneralizedIterativeClosestPoint<PointT, PointT>::MatricesVector;

/// pcl::GeneralizedIterativeClosestPoint::computeCovariances (PCL 1.13), the same arithmetic in the
/// same order, over any search whose input is `cloud`: the k nearest of each point (itself included),
/// their covariance, and U diag(1, 1, epsilon) U^T from its SVD.
void gicpCovariances(const Cloud& cloud, const pcl::search::Search<PointT>& search, int k, double epsilon,
                     Covariances& covs) {
  covs.resize(cloud.size());
  pcl::Indices nn;
  std::vector<float> d2;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (search.nearestKSearch(cloud[i], k, nn, d2) < k)
      throw dw::Error("dw_pcl_pipelines: fewer than --gicp-k points in the cloud");
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int j = 0; j < k; ++j) {
      const PointT& p = cloud[nn[j]];
      mean += Eigen::Vector3d(p.x, p.y, p.z);
      // Float products accumulated in double, as PCL's loop does.
      cov(0, 0) += p.x * p.x;
      cov(1, 0) += p.y * p.x;
      cov(1, 1) += p.y * p.y;
      cov(2, 0) += p.z * p.x;
      cov(2, 1) += p.z * p.y;
      cov(2, 2) += p.z * p.z;
    }
    mean /= double(k);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b <= a; ++b) {
        cov(a, b) /= double(k);
        cov(a, b) -= mean[a] * mean[b];
        cov(b, a) = cov(a, b);
      }
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU);
    const Eigen::Matrix3d& u = svd.matrixU();
    covs[i] = u.col(0) * u.col(0).transpose() + u.col(1) * u.col(1).transpose() +
              epsilon * u.col(2) * u.col(2).transpose();
  }
}

/// PCL's own computeCovariances, reachable from outside (it is protected and takes a KdTree).
struct StockGicp : pcl::GeneralizedIterativeClosestPoint<PointT, PointT> {
  void covariances(const Cloud::ConstPtr& cloud, Covariances& covs) {
    auto tree = std::make_shared<pcl::search::KdTree<PointT>>();
    tree->setInputCloud(cloud);
    covs.resize(cloud->size());
    computeCovariances<PointT>(cloud, tree, covs);
  }
};

double maxDifference(const Covariances& a, const Covariances& b) {
  if (a.size() != b.size()) return 1e300;
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i] - b[i]).cwiseAbs().maxCoeff());
  return m;
}

/// One algorithm on one search: its result count (finite normals, clusters, covariances) and, for
/// gicp-cov, the covariances.
struct Outcome {
  std::size_t result = 0;
  Covariances covs;
};

Outcome runAlgorithm(const std::string& algo, const Cloud::Ptr& cloud, const Options& o, unsigned threads,
                     double tolerance, const pcl::search::Search<PointT>::Ptr& search, bool set_input) {
  Outcome out;
  if (algo == "normals") {
    pcl::NormalEstimationOMP<PointT, pcl::Normal> ne(threads);
    ne.setInputCloud(cloud);
    ne.setSearchMethod(search);
    ne.setKSearch(o.k);
    pcl::PointCloud<pcl::Normal> normals;
    ne.compute(normals);  // calls search->setInputCloud(cloud) itself
    for (const auto& n : normals) out.result += std::isfinite(n.normal_x) ? 1 : 0;
  } else if (algo == "clusters") {
    pcl::EuclideanClusterExtraction<PointT> ec;
    ec.setClusterTolerance(tolerance);
    ec.setMinClusterSize(1);
    ec.setSearchMethod(search);
    ec.setInputCloud(cloud);
    std::vector<pcl::PointIndices> clusters;
    ec.extract(clusters);  // calls search->setInputCloud(cloud, indices) itself
    out.result = clusters.size();
  } else {
    if (set_input) search->setInputCloud(cloud);
    gicpCovariances(*cloud, *search, o.gicp_k, 0.001, out.covs);  // GICP's default epsilon
    out.result = out.covs.size();
  }
  return out;
}

struct Row {
  double incl = 0, build = 0, excl = 0;
  std::size_t result = 0;
  double cov_diff = 0;  ///< gicp-cov: max |difference| to the KdTree's covariances
};

/// Times one algorithm with one search: incl. build, the build alone, excl. build.
Row measure(const std::string& algo, const std::string& which, const Cloud::Ptr& cloud, const Options& o,
            unsigned t, double tolerance, const Covariances* reference, Covariances* keep) {
  Row r;
  Outcome first;
  r.incl = best(o.repeats, t,
                [&] { first = runAlgorithm(algo, cloud, o, t, tolerance, makeSearch(which, t), true); });
  r.result = first.result;
  if (reference) r.cov_diff = maxDifference(first.covs, *reference);
  if (keep) *keep = std::move(first.covs);
  r.build = best(o.repeats, t, [&] { makeSearch(which, t)->setInputCloud(cloud); });
  // The walk keeps its graph across compute() calls on an unchanged cloud, and gicp-cov does not set
  // the input again: time those on a search built beforehand; the trees rebuild inside compute().
  if (which == "delaunay-walk" || algo == "gicp-cov") {
    auto s = makeSearch(which, t);
    if (algo == "clusters") {
      // EuclideanClusterExtraction sets the input with PCLBase's indices (all points, in order); the
      // walk keeps its graph only for the same content and indices.
      auto all = std::make_shared<pcl::Indices>(cloud->size());
      std::iota(all->begin(), all->end(), 0);
      s->setInputCloud(cloud, all);
    } else {
      s->setInputCloud(cloud);
    }
    r.excl = best(o.repeats, t, [&] { runAlgorithm(algo, cloud, o, t, tolerance, s, false); });
  } else {
    r.excl = std::max(0.0, r.incl - r.build);
  }
  return r;
}

std::string cell(const Row& r) {
  char b[64];
  std::snprintf(b, sizeof b, "%.1f / %.1f", r.incl * 1e3, r.excl * 1e3);
  return b;
}

std::string ratio(const Row& peer, const Row& walk) {
  char b[64];
  std::snprintf(b, sizeof b, "%.2fx / %.2fx", peer.incl / walk.incl,
                walk.excl > 0 ? peer.excl / walk.excl : 0.0);
  return b;
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
    csv << "dataset,points,algorithm,parameter,search,threads,time,seconds_incl_build,build_seconds,"
           "seconds_excl_build,result,max_cov_diff\n";
    const std::vector<std::string> searches = searchNames();
    std::printf("| data set | algorithm | threads |");
    for (const auto& s : searches) std::printf(" %s incl. / excl. build (ms) |", s.c_str());
    for (std::size_t s = 0; s + 1 < searches.size(); ++s)
      std::printf(" %s / walk incl. / excl. |", searches[s].c_str());
    std::printf("\n|---|---|---|");
    for (std::size_t s = 0; s < 2 * searches.size() - 1; ++s) std::printf("---|");
    std::printf("\n");
    for (const auto& name : o.datasets) {
      const Cloud::Ptr cloud = load(name);
      const double spacing = meanSpacing(cloud), tolerance = 2.5 * spacing;
      std::cerr << "== " << name << ": " << cloud->size() << " points, mean spacing " << spacing << "\n";
      for (unsigned t : o.threads) {
        for (const std::string& algo : o.algorithms) {
          std::vector<Row> rows;
          Covariances ref_covs;
          for (const auto& which : searches) {
            rows.push_back(measure(algo, which, cloud, o, t, tolerance, rows.empty() ? nullptr : &ref_covs,
                                   rows.empty() ? &ref_covs : nullptr));
            const Row& r = rows.back();
            const std::string param = algo == "normals"    ? "k=" + std::to_string(o.k)
                                      : algo == "clusters" ? "tolerance=" + std::to_string(tolerance)
                                                           : "k=" + std::to_string(o.gicp_k);
            csv << name << "," << cloud->size() << "," << algo << "," << param << "," << which << "," << t
                << "," << (t == 1 ? "cpu" : "wall") << "," << r.incl << "," << r.build << "," << r.excl << ","
                << r.result << "," << r.cov_diff << "\n";
            csv.flush();
          }
          bool same = true;
          double cov_diff = 0;
          for (const Row& r : rows)
            same = same && r.result == rows[0].result, cov_diff = std::max(cov_diff, r.cov_diff);
          std::printf("| %s (%zu) | %s | %u |", name.c_str(), cloud->size(),
                      algo == "normals"    ? ("NormalEstimationOMP k=" + std::to_string(o.k)).c_str()
                      : algo == "clusters" ? "EuclideanClusterExtraction"
                                           : ("GICP covariances k=" + std::to_string(o.gicp_k)).c_str(),
                      t);
          for (const Row& r : rows) std::printf(" %s |", cell(r).c_str());
          for (std::size_t s = 0; s + 1 < rows.size(); ++s)
            std::printf(" %s |", ratio(rows[s], rows.back()).c_str());
          std::printf("%s", same ? "" : "  RESULTS DIFFER (finite normals / clusters)");
          if (algo == "gicp-cov") std::printf("  max |cov - KdTree's| %.2g", cov_diff);
          std::printf("\n");
          if (algo == "gicp-cov") {
            // PCL's own computeCovariances on its KdTree, build inside: the check of the loop above.
            StockGicp g;
            g.setCorrespondenceRandomness(o.gicp_k);
            Covariances covs;
            const double s = best(o.repeats, t, [&] { g.covariances(cloud, covs); });
            csv << name << "," << cloud->size() << ",gicp-cov,k=" << o.gicp_k << ",pcl-gicp-stock," << t
                << "," << (t == 1 ? "cpu" : "wall") << "," << s << ",,," << covs.size() << ","
                << maxDifference(covs, ref_covs) << "\n";
            std::printf(
                "|   | pcl::GICP::computeCovariances (its KdTree, k=%d) | %u | %.1f ms incl. build; max "
                "|cov - the loop's| %.2g |\n",
                o.gicp_k, t, s * 1e3, maxDifference(covs, ref_covs));
          }
        }
      }
    }
    std::cout
        << "(X / walk: search X's time over DelaunayWalk's, > 1 = the walk is faster; one thread: process "
           "CPU time, more: wall clock)\nresults in "
        << o.out << "/\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "dw_pcl_pipelines: error: " << e.what() << "\n";
    return 1;
  }
}
