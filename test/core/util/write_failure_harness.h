/// \file write_failure_harness.h
/// \brief Failed writes without root, for the tests of every writer: a forked child whose file size is
/// capped by RLIMIT_FSIZE (with SIGXFSZ ignored, so a write past the cap returns EFBIG, "File too
/// large"), a child killed between writing and renaming, and the checks that follow (the old target
/// byte for byte, no temporary left in the folder).
#pragma once

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

namespace dw_test {

/// What a forked child did: its exit code (0: returned, 1: threw, 2: threw a non-std exception,
/// -1: killed) and the message of what it threw.
struct ChildOutcome {
  int exit_code = -1;
  int signal = 0;
  std::string message;
};

/// A fresh empty folder under the build tree for one test.
inline std::string freshFolder(const std::string& name) {
  const std::string dir =
      std::string(DW_BINARY_DIR) + "/write_failure/" + name + "_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline std::vector<char> readBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<char>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

/// Writes `n` bytes of a recognisable pattern as the "old" target.
inline std::vector<char> writeOldTarget(const std::string& path, std::size_t n = 4096) {
  std::vector<char> b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = char('A' + (i * 7) % 26);
  std::ofstream(path, std::ios::binary).write(b.data(), std::streamsize(n));
  return b;
}

/// The names in `dir` other than `keep`.
inline std::vector<std::string> otherFiles(const std::string& dir, const std::vector<std::string>& keep) {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    bool kept = false;
    for (const auto& k : keep) kept = kept || k == name;
    if (!kept) out.push_back(name);
  }
  return out;
}

/// Runs `body` in a forked child under RLIMIT_FSIZE = `limit_bytes` (0: no cap) with SIGXFSZ
/// ignored; the child reports an exception's message through a pipe. Only the calling thread exists in
/// the child, so `body` must not need the process's thread pools.
inline ChildOutcome runInChild(std::uint64_t limit_bytes, const std::function<void()>& body) {
  int fds[2];
  if (::pipe(fds) != 0) return {-1, 0, "pipe failed"};
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    ::signal(SIGXFSZ, SIG_IGN);
    if (limit_bytes != 0) {
      const rlimit r{rlim_t(limit_bytes), rlim_t(limit_bytes)};
      ::setrlimit(RLIMIT_FSIZE, &r);
    }
    int code = 0;
    std::string msg;
    try {
      body();
    } catch (const std::exception& e) {
      code = 1;
      msg = e.what();
    } catch (...) {
      code = 2;
    }
    if (!msg.empty() && ::write(fds[1], msg.data(), msg.size()) < 0) code = 3;
    ::_exit(code);  // no atexit handlers, no gtest teardown in the child
  }
  ::close(fds[1]);
  ChildOutcome out;
  char buf[4096];
  for (ssize_t got; (got = ::read(fds[0], buf, sizeof buf)) > 0;) out.message.append(buf, std::size_t(got));
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status)) out.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) out.signal = WTERMSIG(status);
  return out;
}

/// Runs `body` in a forked child and kills it with SIGKILL once it calls `ready()`: with
/// `pause_at_ready` the child stops there for good (a writer killed between its writes and its commit),
/// otherwise ready() returns and the kill lands `delay_us` later, in the middle of what body does next
/// (a kill during a large write). Returns true if the child reached ready() and died of the kill.
inline bool killChild(const std::function<void(const std::function<void()>&)>& body, bool pause_at_ready,
                      unsigned delay_us = 0) {
  int fds[2];
  if (::pipe(fds) != 0) return false;
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    const auto ready = [&] {
      const char c = 'r';
      if (::write(fds[1], &c, 1) != 1) ::_exit(3);
      while (pause_at_ready) ::pause();
    };
    try {
      body(ready);
      if (!pause_at_ready)
        for (;;) ::pause();  // body finished before the kill: wait for it
    } catch (...) {
    }
    ::_exit(2);  // body threw or returned without calling ready()
  }
  ::close(fds[1]);
  char c = 0;
  const bool got = ::read(fds[0], &c, 1) == 1 && c == 'r';
  if (got && delay_us != 0) ::usleep(delay_us);
  ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  ::close(fds[0]);
  return got && WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
}

/// The names in `dir` that look like a temporary of `target_name` (`<name>.tmp.XXXXXX...`).
inline std::vector<std::string> temporariesOf(const std::string& dir, const std::string& target_name) {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(target_name + ".tmp.", 0) == 0) out.push_back(name);
  }
  return out;
}

/// The checks after a failed write: the child threw a message naming `target` and `reason`, the
/// target is `old` byte for byte, and the folder holds nothing but `keep`.
inline void expectFailedWriteLeftTarget(const ChildOutcome& child, const std::string& target,
                                        const std::vector<char>& old, const std::string& reason,
                                        const std::vector<std::string>& keep) {
  EXPECT_EQ(child.exit_code, 1) << "the write should have thrown; message: " << child.message;
  EXPECT_NE(child.message.find(target), std::string::npos)
      << "message does not name the target: " << child.message;
  EXPECT_NE(child.message.find(reason), std::string::npos)
      << "message lacks '" << reason << "': " << child.message;
  EXPECT_TRUE(readBytes(target) == old) << target << " was changed by the failed write";
  const std::string dir = std::filesystem::path(target).parent_path().string();
  EXPECT_EQ(otherFiles(dir, keep), std::vector<std::string>()) << "files left in " << dir;
}

/// True when running as root, for whom a read-only folder is writable.
inline bool runningAsRoot() {
  return ::geteuid() == 0;
}

/// Makes `dir` read-only for the lifetime of the object (restored on destruction).
class ReadOnlyFolder {
 public:
  explicit ReadOnlyFolder(std::string dir) : dir_(std::move(dir)) { ::chmod(dir_.c_str(), 0555); }
  ~ReadOnlyFolder() { ::chmod(dir_.c_str(), 0755); }
  ReadOnlyFolder(const ReadOnlyFolder&) = delete;
  ReadOnlyFolder& operator=(const ReadOnlyFolder&) = delete;

 private:
  std::string dir_;
};

}  // namespace dw_test
