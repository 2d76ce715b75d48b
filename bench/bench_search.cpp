// Google Benchmark: exact nearest-neighbour search, every peer side by side (seed §5).
//
//   Build/<data set>/<method>            structure build time (walk-graph@qhull / @incremental: the
//                                        Delaunay graph by that builder + start locators)
//   NN/<data set>/<method>/threads:<t>   one ICP-like query sequence replayed (rotation 10/10/10 deg,
//                                        up to 30 iterations); ns_per_query is the per-query NN time
//
// Data sets: $DW_BENCH_DATASETS (comma list, default dragon-23k,dragon-100k); brute force only up to
// 11k points, as in the seed. Thread counts of the NN runs: $DW_BENCH_THREADS (comma list, default 1,2;
// e.g. 1,2,4,8,16 on a 16-core machine). Methods: $DW_BENCH_METHODS (comma list, default all; any name
// dw_bench takes, e.g. walk-pnn-optimized-sorted-prefetch@qhull). The protocol runner with CSV output is
// bench/dw_bench.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "common/nn_methods.h"
#include "common/query_replay.h"

namespace {

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

constexpr std::size_t kBruteForceMax = 11000;

struct Fixture {
  dwb::Dataset data;
  std::unique_ptr<dwb::QueryReplay> replay;
};

std::map<std::string, std::shared_ptr<Fixture>>& fixtures() {
  static std::map<std::string, std::shared_ptr<Fixture>> f;
  return f;
}

/// A data set (loaded in main) and its ICP-like sequence, made once and lazily: only benchmarks that
/// run pay for it.
Fixture& fixture(const std::string& name) {
  auto& f = fixtures().at(name);
  if (!f->replay) {
    auto ref = dwb::makeMethod(f->data.size() <= kBruteForceMax ? "brute-force" : "pcl-kdtree");
#ifdef DW_HAVE_NANOFLANN
    if (f->data.size() > kBruteForceMax) ref = dwb::makeMethod("nanoflann");
#endif
    ref->build(f->data.xyz);
    f->replay = std::make_unique<dwb::QueryReplay>(dwb::makeIcpSequence(f->data.xyz, {10, 10, 10}, *ref, 30));
  }
  return *f;
}

void benchBuild(benchmark::State& state, std::string data, std::string method) {
  Fixture& f = fixture(data);
  for (auto _ : state) {
    auto m = dwb::makeMethod(method);
    m->build(f.data.xyz);
    benchmark::DoNotOptimize(m.get());
  }
  state.counters["points"] = double(f.data.size());
}

void benchNn(benchmark::State& state, std::string data, std::string method) {
  Fixture& f = fixture(data);
  auto m = dwb::makeMethod(method);
  m->build(f.data.xyz);
  const unsigned threads = static_cast<unsigned>(state.range(0));
  dwb::NnBatch batch;
  std::vector<std::uint32_t> steps;
  for (auto _ : state) {
    f.replay->run(*m, batch, threads, nullptr);
    benchmark::DoNotOptimize(batch.index.data());
  }
  const double q = double(f.replay->numQueries());
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * q));
  state.counters["ns_per_query"] = benchmark::Counter(
      q * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  if (m->isWalk()) {
    f.replay->run(*m, batch, 1, &steps);
    double sum = 0;
    for (auto s : steps) sum += s;
    state.counters["mean_walk_steps"] = steps.empty() ? 0.0 : sum / steps.size();
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<long> threads;
  const char* tenv = std::getenv("DW_BENCH_THREADS");
  for (const auto& t : splitList(tenv ? tenv : "1,2")) {
    char* end = nullptr;
    const long v = std::strtol(t.c_str(), &end, 10);
    if (*end != '\0' || v < 1 || v > 256) {
      std::cerr << "bench_search: DW_BENCH_THREADS must list thread counts in 1..256, got '" << t << "'\n";
      return 2;
    }
    threads.push_back(v);
  }
  const char* env = std::getenv("DW_BENCH_DATASETS");
  const auto datasets = splitList(env ? env : "dragon-23k,dragon-100k");
  for (const auto& d : datasets) {
    std::size_t n = 0;
    try {
      auto f = std::make_shared<Fixture>();
      f->data = dwb::loadDataset(d);
      n = f->data.size();
      fixtures()[d] = f;
    } catch (const std::exception& e) {
      std::cerr << "bench_search: skipping " << d << ": " << e.what() << "\n";
      continue;
    }
    const char* menv = std::getenv("DW_BENCH_METHODS");
    for (const auto& m : menv ? splitList(menv) : dwb::allMethodNames()) {
      if (m == "brute-force" && n > kBruteForceMax) continue;
      if (!dwb::makeMethod(m)) continue;  // not compiled in
      if (m.rfind("walk-", 0) != 0)       // the walks share one graph build, registered below
        benchmark::RegisterBenchmark(("Build/" + d + "/" + m).c_str(), benchBuild, d, m)
            ->Unit(benchmark::kMillisecond)
            ->MeasureProcessCPUTime()
            ->UseRealTime();
      auto* b = benchmark::RegisterBenchmark(("NN/" + d + "/" + m).c_str(), benchNn, d, m)
                    ->ArgName("threads")
                    ->Unit(benchmark::kMillisecond)
                    ->UseRealTime();
      for (long t : threads) b->Arg(t);
    }
  }
  for (const auto& d : datasets) {
    if (!fixtures().count(d)) continue;
    // The walk graph (Delaunay edges + start locators) by each builder.
    benchmark::RegisterBenchmark(("Build/" + d + "/walk-graph@qhull").c_str(), benchBuild, d,
                                 std::string("walk-zero@qhull"))
        ->Unit(benchmark::kMillisecond)
        ->MeasureProcessCPUTime()
        ->UseRealTime();
    if (dw::haveIncrementalBuilder())
      benchmark::RegisterBenchmark(("Build/" + d + "/walk-graph@incremental").c_str(), benchBuild, d,
                                   std::string("walk-zero@incremental"))
          ->Unit(benchmark::kMillisecond)
          ->MeasureProcessCPUTime()
          ->UseRealTime();
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
