// The LAS reader on foreign, truncated and lying files: dw::las::LasError (a dw::Error) before any
// allocation sized by the header, never another exception or a crash.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/las_writer.h"
#include "robustness_util.h"

using namespace dw;
using namespace dw::las;
using dw_robust::peek;
using dw_robust::poke;

namespace {

std::string tempPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/robustness_" + std::to_string(::getpid()) + "_" + name;
}

/// A valid file of three points, as bytes (LAS 1.2 or 1.4, format 0 or 6).
std::vector<std::uint8_t> validFile(int minor, int format) {
  const std::string path = tempPath("valid.las");
  LasHeader h;
  h.version_minor = std::uint8_t(minor);
  h.point_format = std::uint8_t(format);
  {
    LasWriter w(path, h);
    for (int i = 0; i < 3; ++i) {
      LasRecord r;
      r.X = 100 * i;
      r.Y = -50 * i;
      r.Z = i;
      r.return_number = r.number_of_returns = 1;
      r.classification = 2;
      w.write(r);
    }
    w.close();
  }
  std::ifstream f(path, std::ios::binary);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::remove(path.c_str());
  return bytes;
}

/// Writes `bytes` to a file and reads it both ways; expects a dw::Error and no big allocation.
void expectRejected(const std::vector<std::uint8_t>& bytes, const std::string& what) {
  const std::string path = tempPath("bad.las");
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  for (int way = 0; way < 2; ++way) {
    dw_robust::AllocationProbe probe;
    try {
      if (way == 0) {
        readLasFile(path);
      } else {
        LasReader r(path);
        std::vector<LasRecord> rec;
        while (r.read(rec) > 0) {
        }
      }
      ADD_FAILURE() << what << ": accepted (" << (way ? "LasReader" : "readLasFile") << ")";
    } catch (const Error&) {
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": threw " << typeid(e).name() << " (" << e.what() << "), not dw::Error";
    }
    EXPECT_LE(probe.largest(), (std::size_t(1) << 20) + bytes.size())
        << what << ": allocation sized by the header";
  }
  std::remove(path.c_str());
}

// Header offsets (ASPRS LAS 1.2/1.4).
constexpr std::size_t kVersionMinor = 25, kHeaderSize = 94, kOffsetToPoints = 96, kFormat = 104,
                      kRecordLength = 105, kLegacyCount = 107, kScale = 131, kOffset = 155, kCount64 = 247;

}  // namespace

TEST(LasBadInput, ValidFilesRead) {
  for (int minor : {2, 4}) {
    const auto bytes = validFile(minor, minor == 4 ? 6 : 0);
    const std::string path = tempPath("ok.las");
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    const LasCloud c = readLasFile(path);
    EXPECT_EQ(c.size(), 3u);
    EXPECT_EQ(c.X[2], 200);
    std::remove(path.c_str());
  }
}

TEST(LasBadInput, ForeignAndTruncatedFiles) {
  EXPECT_THROW(readLasFile(tempPath("missing.las")), Error);
  EXPECT_THROW(readLasFile(DW_BINARY_DIR), Error) << "a directory";
  expectRejected({}, "empty file");
  expectRejected(std::vector<std::uint8_t>(400, 0), "zeros");
  const std::string ply = "ply\nformat ascii 1.0\nend_header\n";
  expectRejected(std::vector<std::uint8_t>(ply.begin(), ply.end()), "a PLY file");
  const auto good = validFile(2, 0);
  for (std::size_t len :
       {std::size_t(4), std::size_t(100), std::size_t(226), good.size() - 1, good.size() - 20})
    expectRejected(std::vector<std::uint8_t>(good.begin(), good.begin() + std::ptrdiff_t(len)),
                   "truncated to " + std::to_string(len));
}

TEST(LasBadInput, LyingHeaderFields) {
  const auto good = validFile(2, 0);
  auto edit = [&](const char* what, auto apply) {
    auto f = good;
    apply(f);
    expectRejected(f, what);
  };
  edit("version 1.9", [](auto& f) { f[kVersionMinor] = 9; });
  edit("version 2.0", [](auto& f) { f[kVersionMinor - 1] = 2; });
  edit("LAZ (compressed) format bit", [](auto& f) { f[kFormat] |= 0x80; });
  edit("point format 11", [](auto& f) { f[kFormat] = 11; });
  edit("format 6 in LAS 1.2", [](auto& f) { f[kFormat] = 6; });
  edit("record length 0", [](auto& f) { poke<std::uint16_t>(f, kRecordLength, 0); });
  edit("record length 19 < 20", [](auto& f) { poke<std::uint16_t>(f, kRecordLength, 19); });
  edit("header size 100", [](auto& f) { poke<std::uint16_t>(f, kHeaderSize, 100); });
  edit("points inside the header", [](auto& f) { poke<std::uint32_t>(f, kOffsetToPoints, 200); });
  edit("points past the end", [](auto& f) { poke<std::uint32_t>(f, kOffsetToPoints, 0xFFFFFFF0u); });
  edit("4 points in a file of 3", [](auto& f) { poke<std::uint32_t>(f, kLegacyCount, 4); });
  edit("2^32-1 points", [](auto& f) { poke<std::uint32_t>(f, kLegacyCount, 0xFFFFFFFFu); });
  edit("scale 0", [](auto& f) { poke<double>(f, kScale, 0.0); });
  edit("scale NaN", [](auto& f) { poke<double>(f, kScale + 8, std::numeric_limits<double>::quiet_NaN()); });
  edit("offset Inf", [](auto& f) { poke<double>(f, kOffset + 16, std::numeric_limits<double>::infinity()); });
}

TEST(LasBadInput, Las14PointCountOverflowIsRejected) {
  // Regression guard for B6 (docs/robustness.md; found by fuzz/fuzz_las, fixed in parseHeader): the
  // 64-bit count of LAS 1.4 times the record length can overflow, e.g. 2^62 x 20 wraps to 0, and then
  // passed the truncation check; readLasFile reserved 2^62 records (std::length_error).
  auto f = validFile(4, 0);
  ASSERT_EQ(peek<std::uint16_t>(f, kRecordLength), 20);
  poke<std::uint32_t>(f, kLegacyCount, 0);
  for (std::uint64_t count :
       {std::uint64_t(1) << 62, (std::uint64_t(1) << 62) + 1, std::uint64_t(0xCCCCCCCCCCCCCCCDULL)}) {
    poke<std::uint64_t>(f, kCount64, count);
    expectRejected(f, "LAS 1.4 count " + std::to_string(count));
  }
  // Without overflow the same lie is caught.
  poke<std::uint64_t>(f, kCount64, std::uint64_t(1) << 40);
  expectRejected(f, "LAS 1.4 count 2^40");
}

TEST(LasBadInput, ParseHeaderWithLyingFileSize) {
  const auto good = validFile(2, 0);
  EXPECT_THROW(parseHeader(good.data(), 100, good.size(), "short"), Error);
  EXPECT_THROW(parseHeader(good.data(), good.size(), 230, "file size smaller than the points"), Error);
  EXPECT_NO_THROW(parseHeader(good.data(), good.size(), good.size(), "exact"));
}
