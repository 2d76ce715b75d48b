/// \file test_laz_bad_input.cpp
/// \brief Broken LAZ files: each gives a dw::Error naming the file (and the chunk where one is at
/// fault), never a crash, a hang or an allocation beyond the file: truncation, a corrupt chunk
/// table, a stream that runs out, a point count that disagrees, unknown item versions, a lying VLR,
/// and random byte flips.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "core/las/laz_codec.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/laz_writer.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"

namespace {

std::string tmpPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/test_lazbad_" + std::to_string(::getpid()) + "_" + name;
}

std::vector<unsigned char> readBytes(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<unsigned char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void writeBytes(const std::string& p, const std::vector<unsigned char>& b) {
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

/// A LAZ file of `format` with 20000 points in chunks of 5000.
std::vector<unsigned char> goodLaz(unsigned format) {
  dw::las::LidarGenOptions o;
  o.num_points = 20000;
  dw::las::LasHeader h = dw::las::syntheticHeader(o);
  h.point_format = std::uint8_t(format);
  h.version_minor = format >= 6 ? 4 : 2;
  const std::string p = tmpPath("good.laz");
  {
    dw::las::LazWriter w(p, h, 2, 5000);
    dw::las::generateLidar(o, [&](const dw::las::LasRecord& r) { w.write(r); });
    w.close();
  }
  auto b = readBytes(p);
  std::remove(p.c_str());
  return b;
}

/// Reads the whole file both ways; returns the error message ("" if it read).
std::string errorOf(const std::vector<unsigned char>& bytes, const std::string& name) {
  const std::string p = tmpPath(name);
  writeBytes(p, bytes);
  std::string msg;
  try {
    dw::las::LasReader r(p);
    std::vector<dw::las::LasRecord> v;
    while (r.read(v, 7000) > 0) {
    }
    dw::las::readLasFile(p);
  } catch (const dw::Error& e) {
    msg = e.what();
  }
  std::remove(p.c_str());
  return msg;
}

std::uint32_t u32(const std::vector<unsigned char>& b, std::size_t at) {
  std::uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

void expectError(const std::vector<unsigned char>& b, const std::string& name, const std::string& needle) {
  const std::string msg = errorOf(b, name);
  EXPECT_NE(msg.find(name), std::string::npos) << "message does not name the file: " << msg;
  EXPECT_NE(msg.find(needle), std::string::npos) << "expected '" << needle << "' in: " << msg;
}

TEST(LazBadInput, EachDefectGivesAnErrorNamingFileAndWhat) {
  for (unsigned format : {1u, 8u}) {
    const auto good = goodLaz(format);
    ASSERT_EQ(errorOf(good, "good.laz"), "");
    const std::size_t header = format >= 6 ? 375 : 227, vlr = header + 54, points = u32(good, 96);
    std::int64_t table;
    std::memcpy(&table, good.data() + points, 8);

    auto b = good;
    b.resize(std::size_t(table) - 100);  // cut inside the last chunk (and the table is gone)
    expectError(b, "truncated.laz", "chunk table");

    b = good;
    std::memcpy(b.data() + points, "\xff\xff\xff\x7f\0\0\0\0", 8);  // table offset beyond the file
    expectError(b, "table_offset.laz", "chunk table");

    b = good;
    for (std::size_t i = std::size_t(table) + 8; i < b.size(); ++i) b[i] = std::uint8_t(b[i] * 37 + 11);
    expectError(b, "table_body.laz", "");

    b = good;
    b[std::size_t(table) + 4] = 200;  // 200 chunks for 20000 points of 5000 per chunk
    expectError(b, "table_count.laz", "chunk");

    {  // the first chunk's stream shortened by 40 bytes, with a chunk table that agrees
      namespace laz = dw::las::laz;
      laz::ChunkTable t;
      laz::decodeChunkTable(good.data() + table + 8, good.size() - std::size_t(table) - 8, 4, false, t);
      std::size_t chunk0_end = points + 8 + t.bytes[0];
      t.bytes[0] -= 40;
      b.assign(good.begin(), good.begin() + std::ptrdiff_t(chunk0_end - 40));
      b.insert(b.end(), good.begin() + std::ptrdiff_t(chunk0_end), good.begin() + std::ptrdiff_t(table));
      const auto body = laz::encodeChunkTable(t, false);
      b.insert(b.end(), body.begin(), body.end());
      const std::int64_t moved = table - 40;
      std::memcpy(b.data() + points, &moved, 8);
      expectError(b, "short_chunk.laz", "chunk 0");
    }

    b = good;  // header count disagrees with the chunks
    if (format >= 6) {
      const std::uint64_t n = 20001;
      std::memcpy(b.data() + 247, &n, 8);
    } else {
      const std::uint32_t n = 20001;
      std::memcpy(b.data() + 107, &n, 4);
    }
    expectError(b, "count.laz", "point count mismatch");

    b = good;
    b[vlr + 38] = 9;  // version of the first item
    expectError(b, "item_version.laz", "version 9 is not supported");

    b = good;
    b[vlr + 0] = 7;  // compressor
    expectError(b, "compressor.laz", "compressor 7");

    b = good;
    b[header + 20] = 0xFF;  // the VLR says it is longer than the space before the points
    b[header + 21] = 0x7F;
    expectError(b, "vlr_length.laz", "run past");
  }
}

TEST(LazBadInput, DecodersReportAStreamThatRunsOut) {
  for (unsigned format : {1u, 8u}) {
    const unsigned len = unsigned(dw::las::baseRecordSize(format));
    std::mt19937 rng(format);
    std::vector<std::uint8_t> records(3000 * len);
    for (auto& c : records) c = std::uint8_t(rng());
    const auto v = dw::las::laz::defaultLaszipVlr(format, 0, 50000);
    std::vector<std::uint8_t> chunk, back(records.size());
    dw::las::laz::makeChunkEncoder(v, len)->encode(records.data(), 3000, chunk);
    auto dec = dw::las::laz::makeChunkDecoder(v, len);
    try {
      dec->decode(chunk.data(), chunk.size() / 2, 3000, back.data());
      ADD_FAILURE() << "half a chunk decoded without an error";
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      EXPECT_TRUE(msg.find("runs out") != std::string::npos || msg.find("runs past") != std::string::npos)
          << msg;
    }
  }
}

TEST(LazBadInput, RandomByteFlipsNeverCrash) {
  for (unsigned format : {1u, 8u}) {
    const auto good = goodLaz(format);
    std::mt19937 rng(7 + format);
    for (int trial = 0; trial < 60; ++trial) {
      auto b = good;
      for (int k = 0; k < 1 + trial % 4; ++k) b[rng() % b.size()] ^= std::uint8_t(1u << (rng() % 8));
      errorOf(b, "flip.laz");  // either reads (a flip in a stream gives other points) or throws dw::Error
    }
  }
}

}  // namespace
