// dw::SafeOutputFile and the path helpers for libraries: a target changes only by a complete commit;
// a write past RLIMIT_FSIZE, a read-only folder, a killed writer or a library that wrote nothing leave
// the old target byte for byte and no temporary behind; permissions, symbolic links and devices.
#include <gtest/gtest.h>
#include <sys/file.h>
#include <sys/stat.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/util/write_failure_harness.h"
#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"

namespace {

using dw_test::freshFolder;
using dw_test::readBytes;

std::vector<char> bytesOf(const std::string& s) {
  return std::vector<char>(s.begin(), s.end());
}

void writeAll(dw::SafeOutputFile& f, const std::string& s) {
  f.write(s.data(), s.size());
}

/// Moves a file's modification time `seconds` into the past.
void backdate(const std::string& path, int seconds) {
  struct stat st;
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  const timespec times[2] = {{st.st_mtime - seconds, 0}, {st.st_mtime - seconds, 0}};
  ASSERT_EQ(::utimensat(AT_FDCWD, path.c_str(), times, 0), 0);
}

mode_t modeOf(const std::string& path) {
  struct stat st;
  EXPECT_EQ(::stat(path.c_str(), &st), 0) << path;
  return st.st_mode & 07777;
}

TEST(SafeOutputFile, CommitReplacesTheTargetAndLeavesNoTemporary) {
  const std::string dir = freshFolder("commit");
  const std::string target = dir + "/out.bin";
  dw_test::writeOldTarget(target);
  dw::SafeOutputFile f(target);
  EXPECT_EQ(f.target(), target);
  EXPECT_EQ(f.temporaryPath().rfind(target + ".tmp.", 0), 0u) << f.temporaryPath();
  writeAll(f, "new contents");
  EXPECT_EQ(readBytes(target).size(), 4096u) << "the target changed before the commit";
  f.commit();
  EXPECT_FALSE(f.isOpen());
  EXPECT_EQ(readBytes(target), bytesOf("new contents"));
  EXPECT_EQ(dw_test::otherFiles(dir, {"out.bin"}), std::vector<std::string>());
  // A target that did not exist appears only on commit.
  const std::string fresh = dir + "/fresh.bin";
  dw::SafeOutputFile g(fresh);
  writeAll(g, "x");
  EXPECT_FALSE(std::filesystem::exists(fresh));
  g.commit();
  EXPECT_EQ(readBytes(fresh), bytesOf("x"));
}

TEST(SafeOutputFile, WithoutCommitTheTemporaryGoesAndTheTargetStays) {
  const std::string dir = freshFolder("discard");
  const std::string target = dir + "/out.bin";
  const auto old = dw_test::writeOldTarget(target);
  {
    dw::SafeOutputFile f(target);
    writeAll(f, "half");
  }
  EXPECT_EQ(readBytes(target), old);
  EXPECT_EQ(dw_test::otherFiles(dir, {"out.bin"}), std::vector<std::string>());
  dw::SafeOutputFile moved;
  {
    dw::SafeOutputFile f(target);
    writeAll(f, "moved");
    moved = std::move(f);
    EXPECT_FALSE(f.isOpen());
  }
  moved.commit();  // the moved-to object owns the temporary
  EXPECT_EQ(readBytes(target), bytesOf("moved"));
}

TEST(SafeOutputFile, SeekPatchesBytesAlreadyWritten) {
  const std::string dir = freshFolder("seek");
  const std::string target = dir + "/out.bin";
  dw::SafeOutputFile f(target);
  writeAll(f, "0000payload");
  EXPECT_EQ(f.tell(), 11u);
  f.seek(0);
  writeAll(f, "HEAD");
  f.seekToEnd();
  writeAll(f, "!");
  f.commit();
  EXPECT_EQ(readBytes(target), bytesOf("HEADpayload!"));
}

TEST(SafeOutputFile, FileTooLargeKeepsTheOldTargetAndNamesTheReason) {
  const std::string dir = freshFolder("efbig");
  const std::string target = dir + "/out.bin";
  const auto old = dw_test::writeOldTarget(target);
  const std::string big(64 * 1024, 'z');
  for (const bool explicit_commit : {true, false}) {
    const auto child = dw_test::runInChild(16 * 1024, [&] {
      dw::SafeOutputFile f(target);
      for (int k = 0; k < 4; ++k) writeAll(f, big);
      if (explicit_commit) f.commit();
    });
    dw_test::expectFailedWriteLeftTarget(child, target, old, "File too large", {"out.bin"});
  }
  // The same write without the cap succeeds, so the cap is what failed it.
  const auto child = dw_test::runInChild(0, [&] {
    dw::SafeOutputFile f(target);
    writeAll(f, big);
    f.commit();
  });
  EXPECT_EQ(child.exit_code, 0) << child.message;
  EXPECT_EQ(readBytes(target).size(), big.size());
}

TEST(SafeOutputFile, BufferedBytesThatFailAtCommitKeepTheOldTarget) {
  const std::string dir = freshFolder("efbig_commit");
  const std::string target = dir + "/out.bin";
  const auto old = dw_test::writeOldTarget(target);
  // 3000 bytes sit in stdio's buffer until commit()'s fflush meets the 1000-byte cap.
  const auto child = dw_test::runInChild(1000, [&] {
    dw::SafeOutputFile f(target);
    writeAll(f, std::string(3000, 'q'));
    f.commit();
  });
  dw_test::expectFailedWriteLeftTarget(child, target, old, "File too large", {"out.bin"});
}

TEST(SafeOutputFile, ReadOnlyFolderIsAClearErrorAndChangesNothing) {
  if (dw_test::runningAsRoot()) GTEST_SKIP() << "running as root: a read-only folder does not stop root";
  const std::string dir = freshFolder("readonly");
  const std::string target = dir + "/out.bin";
  const auto old = dw_test::writeOldTarget(target);
  dw_test::ReadOnlyFolder lock(dir);
  try {
    dw::SafeOutputFile f(target);
    ADD_FAILURE() << "opened a file in a read-only folder";
  } catch (const dw::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(target), std::string::npos) << msg;
    EXPECT_NE(msg.find("Permission denied"), std::string::npos) << msg;
  }
  EXPECT_THROW(dw::temporaryPathFor(target), dw::Error);
  EXPECT_EQ(readBytes(target), old);
  EXPECT_EQ(dw_test::otherFiles(dir, {"out.bin"}), std::vector<std::string>());
}

TEST(SafeOutputFile, MissingFolderNamesTheTargetAndTheReason) {
  try {
    dw::SafeOutputFile f("/nonexistent-dw-dir/out.bin");
    ADD_FAILURE() << "opened a file in a missing folder";
  } catch (const dw::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("/nonexistent-dw-dir/out.bin"), std::string::npos) << msg;
    EXPECT_NE(msg.find("No such file or directory"), std::string::npos) << msg;
  }
  EXPECT_THROW(dw::SafeOutputFile(""), dw::Error);
}

TEST(SafeOutputFile, KilledWriterLeavesTheTargetAndAStrayThatALaterWriteRemoves) {
  const std::string dir = freshFolder("killed");
  const std::string target = dir + "/out.bin";
  const auto old = dw_test::writeOldTarget(target);
  ASSERT_TRUE(dw_test::killChild(
      [&](const std::function<void()>& ready) {
        dw::SafeOutputFile f(target);
        writeAll(f, std::string(100000, 'k'));
        ready();  // killed here, before commit()
        f.commit();
      },
      true));
  EXPECT_EQ(readBytes(target), old);
  const auto strays = dw_test::temporariesOf(dir, "out.bin");
  ASSERT_EQ(strays.size(), 1u) << "the killed writer's temporary";
  const std::string stray = dir + "/" + strays[0];

  // Younger than the age guard: a new writer leaves it (it might be a live writer's fresh file).
  {
    dw::SafeOutputFile f(target);
    EXPECT_TRUE(std::filesystem::exists(stray));
  }
  // Older and unlocked (its writer is dead): the next open removes it.
  backdate(stray, 60);
  {
    dw::SafeOutputFile f(target);
    EXPECT_FALSE(std::filesystem::exists(stray));
    writeAll(f, "after");
    f.commit();
  }
  EXPECT_EQ(readBytes(target), bytesOf("after"));
  EXPECT_EQ(dw_test::otherFiles(dir, {"out.bin"}), std::vector<std::string>());
}

TEST(SafeOutputFile, ALiveWritersTemporaryIsNeverRemoved) {
  const std::string dir = freshFolder("live");
  const std::string target = dir + "/out.bin";
  dw::SafeOutputFile first(target);
  writeAll(first, "first");
  backdate(first.temporaryPath(), 3600);  // old, but its lock says a writer holds it
  {
    dw::SafeOutputFile second(target);
    writeAll(second, "second");
    second.commit();
  }
  ASSERT_TRUE(std::filesystem::exists(first.temporaryPath()));
  first.commit();  // last commit wins
  EXPECT_EQ(readBytes(target), bytesOf("first"));
  // Names that only resemble a temporary are never touched.
  for (const char* name :
       {"out.bin.tmp.12345", "out.bin.tmp.1234567", "out.bin.tmp.ab-def", "other.tmp.abcdef"}) {
    dw_test::writeOldTarget(dir + "/" + name, 10);
    backdate(dir + "/" + name, 3600);
  }
  dw::SafeOutputFile third(target);
  third.commit();
  EXPECT_EQ(dw_test::otherFiles(dir, {"out.bin"}).size(), 4u);
}

TEST(SafeOutputFile, PermissionsAreAFreshFilesOrTheExistingTargets) {
  const std::string dir = freshFolder("mode");
  const mode_t saved = ::umask(027);
  {
    dw::SafeOutputFile f(dir + "/fresh.bin");
    f.commit();
  }
  EXPECT_EQ(modeOf(dir + "/fresh.bin"), mode_t(0640)) << "0666 through umask 027";
  dw_test::writeOldTarget(dir + "/existing.bin");
  ASSERT_EQ(::chmod((dir + "/existing.bin").c_str(), 0604), 0);
  {
    dw::SafeOutputFile f(dir + "/existing.bin");
    f.commit();
  }
  EXPECT_EQ(modeOf(dir + "/existing.bin"), mode_t(0604)) << "an overwritten file keeps its bits";
  const std::string tif = dw::temporaryPathFor(dir + "/dem.tif");
  EXPECT_EQ(modeOf(tif), mode_t(0640));
  dw::discardTemporary(tif);
  ::umask(saved);
}

TEST(SafeOutputFile, SymbolicLinkTargetReplacesTheFileItNames) {
  const std::string dir = freshFolder("symlink");
  std::filesystem::create_directories(dir + "/real");
  dw_test::writeOldTarget(dir + "/real/data.bin");
  std::filesystem::create_symlink("real/data.bin", dir + "/link.bin");
  dw::SafeOutputFile f(dir + "/link.bin");
  EXPECT_EQ(std::filesystem::path(f.temporaryPath()).parent_path(),
            std::filesystem::canonical(dir + "/real"));
  writeAll(f, "through the link");
  f.commit();
  EXPECT_TRUE(std::filesystem::is_symlink(dir + "/link.bin"));
  EXPECT_EQ(readBytes(dir + "/real/data.bin"), bytesOf("through the link"));
}

TEST(SafeOutputFile, DevicesAreWrittenInPlace) {
  dw::SafeOutputFile f("/dev/null");
  EXPECT_TRUE(f.temporaryPath().empty());
  writeAll(f, "discarded by the device");
  f.commit();
  EXPECT_TRUE(std::filesystem::is_character_file("/dev/null"));
  EXPECT_EQ(dw::temporaryPathFor("/dev/null"), "/dev/null");
  dw::commitTemporary("/dev/null", "/dev/null");
  dw::discardTemporary("/dev/null");  // not ours: left alone
  EXPECT_TRUE(std::filesystem::is_character_file("/dev/null"));
}

TEST(SafeOutputFile, TemporaryPathForALibraryThatTakesAPath) {
  const std::string dir = freshFolder("library");
  const std::string target = dir + "/dem.tif";
  const auto old = dw_test::writeOldTarget(target);
  // A library that opens the path itself, as GDAL does.
  const auto library = [](const std::string& path, std::size_t n) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) throw dw::Error(path + ": library cannot open");
    const std::string data(n, 'g');
    const bool ok = std::fwrite(data.data(), 1, n, f) == n;
    if (std::fclose(f) != 0 || !ok) throw dw::Error(path + ": library write failed");
  };
  const std::string tmp = dw::temporaryPathFor(target);
  EXPECT_EQ(tmp.rfind(target + ".tmp.", 0), 0u) << tmp;
  EXPECT_EQ(std::filesystem::path(tmp).extension(), ".tif") << "libraries pick the format by extension";
  EXPECT_TRUE(std::filesystem::exists(tmp)) << "created, so no one else takes the name";
  library(tmp, 5000);
  EXPECT_EQ(readBytes(target), old);
  dw::commitTemporary(tmp, target);
  EXPECT_EQ(readBytes(target).size(), 5000u);
  EXPECT_EQ(dw_test::otherFiles(dir, {"dem.tif"}), std::vector<std::string>());

  // A library that wrote nothing (and said nothing): refused, the target stays.
  const auto before = readBytes(target);
  const std::string empty = dw::temporaryPathFor(target);
  EXPECT_THROW(dw::commitTemporary(empty, target), dw::Error);
  EXPECT_EQ(readBytes(target), before);
  EXPECT_EQ(dw_test::otherFiles(dir, {"dem.tif"}), std::vector<std::string>());

  // A library write past RLIMIT_FSIZE: the caller discards, as the header shows.
  const auto child = dw_test::runInChild(2000, [&] {
    const std::string t = dw::temporaryPathFor(target);
    try {
      library(t, 5000);
      dw::commitTemporary(t, target);
    } catch (...) {
      dw::discardTemporary(t);
      throw;
    }
  });
  dw_test::expectFailedWriteLeftTarget(child, target, before, "library write failed", {"dem.tif"});
}

}  // namespace
