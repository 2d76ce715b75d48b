// The apps over an existing output that they fail to write: `dw_graph -o existing.graph`,
// `dw_tin ... -o existing.ply` and `dw_lidar_gen -o existing.las|.laz` run under RLIMIT_FSIZE (SIGXFSZ
// ignored, so the write fails with EFBIG) or into a read-only folder exit non-zero, say which file
// failed and why, and leave the existing file byte for byte with no partial file beside it.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <string>
#include <vector>

#include "core/util/write_failure_harness.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"

namespace {

struct AppRun {
  int exit_code = -1;
  std::string output;  ///< stdout and stderr together
};

/// Runs `app args...` with RLIMIT_FSIZE = limit_bytes (0: no cap) and SIGXFSZ ignored (both survive
/// exec), its stdout and stderr captured through a pipe (a pipe is not capped by RLIMIT_FSIZE).
AppRun runApp(const std::string& app, const std::vector<std::string>& args, std::uint64_t limit_bytes) {
  int fds[2];
  if (::pipe(fds) != 0) return {};
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    ::dup2(fds[1], 1);
    ::dup2(fds[1], 2);
    ::signal(SIGXFSZ, SIG_IGN);
    if (limit_bytes != 0) {
      const rlimit r{rlim_t(limit_bytes), rlim_t(limit_bytes)};
      ::setrlimit(RLIMIT_FSIZE, &r);
    }
    std::vector<char*> argv{const_cast<char*>(app.c_str())};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(app.c_str(), argv.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  AppRun run;
  char buf[4096];
  for (ssize_t got; (got = ::read(fds[0], buf, sizeof buf)) > 0;) run.output.append(buf, std::size_t(got));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

/// Checks a failed run: non-zero exit, the target and the reason named, the target unchanged, and
/// nothing else in its folder but `keep`.
void expectFailedRun(const AppRun& run, const std::string& target, const std::vector<char>& old,
                     const std::string& reason, const std::vector<std::string>& keep) {
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find(target), std::string::npos) << "the error does not name the file:\n"
                                                        << run.output;
  EXPECT_NE(run.output.find(reason), std::string::npos) << "the error lacks '" << reason << "':\n"
                                                        << run.output;
  EXPECT_TRUE(dw_test::readBytes(target) == old) << target << " was changed by the failed run";
  EXPECT_EQ(dw_test::otherFiles(std::filesystem::path(target).parent_path().string(), keep),
            std::vector<std::string>());
}

const std::string kBunny = std::string(DW_TEST_DATA_DIR) + "/bun000.ply";

TEST(AppsFailedWrite, DwGraphKeepsTheExistingGraphUnderAFileSizeCap) {
  const std::string dir = dw_test::freshFolder("app_graph");
  const std::string target = dir + "/existing.graph";
  const auto old = dw_test::writeOldTarget(target);
  const std::vector<std::string> args = {kBunny, "-o", target, "--threads", "1", "--quiet"};
  expectFailedRun(runApp(DW_GRAPH_APP, args, 256 * 1024), target, old, "File too large", {"existing.graph"});
  // Uncapped, the same command replaces the file.
  const AppRun ok = runApp(DW_GRAPH_APP, args, 0);
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_GT(dw_test::readBytes(target).size(), 256u * 1024u);
  EXPECT_EQ(dw_test::otherFiles(dir, {"existing.graph"}), std::vector<std::string>());
}

TEST(AppsFailedWrite, DwGraphInAReadOnlyFolderKeepsTheExistingGraph) {
  if (dw_test::runningAsRoot()) GTEST_SKIP() << "running as root: a read-only folder does not stop root";
  const std::string dir = dw_test::freshFolder("app_graph_readonly");
  const std::string target = dir + "/existing.graph";
  const auto old = dw_test::writeOldTarget(target);
  dw_test::ReadOnlyFolder lock(dir);
  expectFailedRun(runApp(DW_GRAPH_APP, {kBunny, "-o", target, "--quiet"}, 0), target, old,
                  "Permission denied", {"existing.graph"});
}

TEST(AppsFailedWrite, DwTinKeepsTheExistingPlyUnderAFileSizeCap) {
  const std::string dir = dw_test::freshFolder("app_tin");
  const std::string input = dir + "/tile.las";
  dw::las::LidarGenOptions o;
  o.num_points = 20000;
  dw::las::writeSyntheticLas(input, o);
  const std::string target = dir + "/existing.ply";
  const auto old = dw_test::writeOldTarget(target);
  const std::vector<std::string> args = {input, "-o", target, "--threads", "1", "--quiet"};
  // The cap is above the input's size: reading it is fine, the mesh (about 0.8 MB) is not.
  expectFailedRun(runApp(DW_TIN_APP, args, 700 * 1024), target, old, "File too large",
                  {"existing.ply", "tile.las"});
  const AppRun ok = runApp(DW_TIN_APP, args, 0);
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_GT(dw_test::readBytes(target).size(), 700u * 1024u);
}

TEST(AppsFailedWrite, DwLidarGenKeepsTheExistingLasAndLazUnderAFileSizeCap) {
  const std::string dir = dw_test::freshFolder("app_lidar_gen");
  for (const char* name : {"existing.las", "existing.laz"}) {
    SCOPED_TRACE(name);
    const std::string target = dir + "/" + name;
    const auto old = dw_test::writeOldTarget(target);
    expectFailedRun(runApp(DW_LIDAR_GEN_APP, {"-n", "100k", "--seed", "2", "-o", target}, 64 * 1024), target,
                    old, "File too large", {"existing.las", "existing.laz"});
  }
}

}  // namespace
