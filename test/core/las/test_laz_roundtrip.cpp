/// \file test_laz_roundtrip.cpp
/// \brief The LAZ encoder against the decoder: every format 0-3 and 6-8, with and without extra
/// bytes, on random records (every model's extreme paths: huge jumps, GPS sequences, channel
/// switches) and on the synthetic survey; the decoded records equal the encoded ones byte for byte,
/// and LazWriter's files decode to the LasWriter twin's records.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "core/las/laz_codec.h"
#include "core/las/laz_reader.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/las_writer.h"
#include "pcl_delaunay_walk/core/las/laz_writer.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"

namespace {

using dw::las::LasRecord;
namespace laz = dw::las::laz;

/// Random records whose fields mix runs of equal values (the "unchanged" paths) with arbitrary ones.
std::vector<std::uint8_t> randomRecords(unsigned format, unsigned extra, std::size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  const unsigned len = unsigned(dw::las::baseRecordSize(format)) + extra;
  std::vector<std::uint8_t> out(n * len);
  LasRecord r;
  double gps = 1000.0;
  double other_gps = 5e8;
  std::vector<std::uint8_t> ex(extra, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned mode = unsigned(rng() % 8);
    if (mode == 0) {  // arbitrary values everywhere
      r.X = std::int32_t(rng());
      r.Y = std::int32_t(rng());
      r.Z = std::int32_t(rng());
      r.intensity = std::uint16_t(rng());
    } else if (mode < 6) {  // a scan line
      r.X += int(rng() % 200) - 100;
      r.Y += int(rng() % 50);
      r.Z += int(rng() % 30) - 15;
      if (rng() % 2) r.intensity = std::uint16_t(r.intensity + int(rng() % 9) - 4);
    }
    const unsigned max_ret = format <= 5 ? 7 : 15;
    if (rng() % 4 == 0) {
      r.number_of_returns = std::uint8_t(rng() % (max_ret + 1));
      r.return_number = std::uint8_t(rng() % (max_ret + 1));
    }
    if (rng() % 5 == 0) r.classification = std::uint8_t(rng() % (format <= 5 ? 32 : 256));
    if (rng() % 7 == 0) r.flags = std::uint8_t(rng() % (format <= 5 ? 8 : 16));
    if (rng() % 6 == 0)
      r.scan_angle = format <= 5 ? std::int16_t(int(rng() % 256) - 128) : std::int16_t(rng());
    if (rng() % 9 == 0) r.user_data = std::uint8_t(rng());
    if (rng() % 11 == 0) r.point_source_id = std::uint16_t(rng());
    switch (rng() % 10) {  // GPS: regular pulses, repeats, a second sequence, huge jumps
      case 0: break;
      case 1: std::swap(gps, other_gps); break;
      case 2: gps = double(rng() % 1000000000ull) * 1e-3; break;
      case 3: gps += 1e-5 * double(rng() % 1000); break;
      default: gps += 1e-5;
    }
    r.gps_time = gps;
    for (auto& c : r.rgb)
      if (rng() % 3 == 0) c = std::uint16_t(rng() % 2 ? rng() : (c + rng() % 5));
    if (rng() % 4 == 0) r.nir = std::uint16_t(rng());
    for (auto& b : ex)
      if (rng() % 3 == 0) b = std::uint8_t(rng());
    std::uint8_t* p = out.data() + i * len;
    dw::las::encodeRecord(r, format, p);
    if (format >= 6 && rng() % 13 == 0) p[15] = std::uint8_t((p[15] & 0xCF) | ((rng() % 4) << 4));  // channel
    if (format >= 6 && rng() % 17 == 0) p[15] ^= 0xC0;  // scan direction, edge of flight line
    if (format <= 5 && rng() % 17 == 0) p[14] ^= 0xC0;
    if (extra) std::memcpy(p + len - extra, ex.data(), extra);
  }
  return out;
}

void expectChunkRoundTrip(unsigned format, unsigned extra, std::size_t n, unsigned seed) {
  const unsigned len = unsigned(dw::las::baseRecordSize(format)) + extra;
  const laz::LaszipVlr v = laz::defaultLaszipVlr(format, extra, 50000);
  ASSERT_NO_THROW(laz::validateItems(v, format, len));
  const auto records = randomRecords(format, extra, n, seed);
  auto enc = laz::makeChunkEncoder(v, len);
  auto dec = laz::makeChunkDecoder(v, len);
  for (int round = 0; round < 2; ++round) {  // the second round reuses the models of the first
    std::vector<std::uint8_t> chunk, back(records.size());
    enc->encode(records.data(), n, chunk);
    dec->decode(chunk.data(), chunk.size(), n, back.data());
    std::size_t bad = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (std::memcmp(back.data() + i * len, records.data() + i * len, len) != 0 && bad++ < 3)
        ADD_FAILURE() << "format " << format << " extra " << extra << " point " << i << " differs";
    EXPECT_EQ(bad, 0u);
  }
}

TEST(LazRoundTrip, EveryFormatWithAndWithoutExtraBytesDecodesToTheEncodedRecords) {
  for (unsigned format : {0u, 1u, 2u, 3u, 6u, 7u, 8u})
    for (unsigned extra : {0u, 5u})
      for (std::size_t n : {std::size_t(1), std::size_t(2), std::size_t(20000)})
        expectChunkRoundTrip(format, extra, n, format * 100 + extra + unsigned(n));
}

TEST(LazRoundTrip, ConstantFieldsLeaveLayersEmptyAndStillDecode) {
  for (unsigned format : {1u, 8u}) {
    const unsigned len = unsigned(dw::las::baseRecordSize(format)) + 2;
    std::vector<std::uint8_t> records(1000 * len, 0);
    for (std::size_t i = 0; i < 1000; ++i) {
      const std::int32_t x = std::int32_t(i);
      std::memcpy(records.data() + i * len, &x, 4);
    };
    const laz::LaszipVlr v = laz::defaultLaszipVlr(format, 2, 50000);
    std::vector<std::uint8_t> chunk, back(records.size());
    laz::makeChunkEncoder(v, len)->encode(records.data(), 1000, chunk);
    laz::makeChunkDecoder(v, len)->decode(chunk.data(), chunk.size(), 1000, back.data());
    EXPECT_EQ(back, records) << format;
  }
}

std::string tmpPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/test_laz_" + std::to_string(::getpid()) + "_" + name;
}

TEST(LazRoundTrip, LazWriterFilesReadBackAsTheLasTwin) {
  for (unsigned format : {0u, 1u, 2u, 3u, 6u, 7u, 8u}) {
    dw::las::LidarGenOptions o;
    o.num_points = 120000;
    o.seed = format + 1;
    dw::las::LasHeader h = dw::las::syntheticHeader(o);
    h.point_format = std::uint8_t(format);
    h.version_minor = format >= 6 ? 4 : 2;
    const std::string las = tmpPath(std::to_string(format) + ".las"),
                      lz = tmpPath(std::to_string(format) + ".laz");
    {
      dw::las::LasWriter a(las, h, 3);
      dw::las::LazWriter b(lz, h, 3, 25000);
      dw::las::generateLidar(o, [&](const LasRecord& r) {
        LasRecord q = r;
        q.rgb[0] = std::uint16_t(r.Z);
        q.rgb[1] = std::uint16_t(r.intensity);
        q.nir = std::uint16_t(r.X);
        a.write(q);
        b.write(q);
      });
      a.close();
      b.close();
    }
    dw::las::LasReader ra(las), rb(lz);
    ASSERT_EQ(ra.header().point_count, rb.header().point_count);
    EXPECT_EQ(ra.header().point_format, rb.header().point_format);
    std::vector<LasRecord> va, vb;
    while (ra.read(va, 30000) > 0) {
      ASSERT_EQ(rb.read(vb, 30000), va.size());
      for (std::size_t i = 0; i < va.size(); ++i) {
        ASSERT_EQ(std::memcmp(&va[i].X, &vb[i].X, 12), 0) << format << " " << i;
        ASSERT_EQ(va[i].gps_time, vb[i].gps_time);
        ASSERT_EQ(va[i].intensity, vb[i].intensity);
        ASSERT_EQ(va[i].classification, vb[i].classification);
        ASSERT_EQ(va[i].rgb[1], vb[i].rgb[1]);
        ASSERT_EQ(va[i].nir, vb[i].nir);
      }
    }
    if (!std::getenv("DW_KEEP_LAZ")) {
      std::remove(las.c_str());
      std::remove(lz.c_str());
    }
  }
}

/// Variable chunks: chunks of 1 to chunk_size points, cut wherever the caller asks, and one cut by
/// the buffer's cap; the table's counts give the chunk boundaries back, and every reader (streaming
/// with seeks, parallel whole file, class filter) returns the LAS twin's records.
TEST(LazRoundTrip, VariableChunksKeepTheirSizesAndReadBackAsTheLasTwin) {
  for (unsigned format : {1u, 8u}) {
    dw::las::LidarGenOptions o;
    o.num_points = 40000;
    o.seed = 11 + format;
    dw::las::LasHeader h = dw::las::syntheticHeader(o);
    h.point_format = std::uint8_t(format);
    h.version_minor = format >= 6 ? 4 : 2;
    const std::string las = tmpPath("var" + std::to_string(format) + ".las"),
                      lz = tmpPath("var" + std::to_string(format) + ".laz");
    // Cuts after these many points of the current chunk; 9000 exceeds the cap and is cut at 8000.
    const std::vector<std::uint64_t> pattern = {1, 5000, 9000, 2, 7777, 3000};
    std::vector<std::uint64_t> expect_counts;
    {
      dw::las::LasWriter a(las, h);
      dw::las::LazWriter b(lz, h, 0, 8000, dw::las::LazChunking::kVariable);
      std::uint64_t in_chunk = 0, n = 0;
      std::size_t k = 0;
      dw::las::generateLidar(o, [&](const LasRecord& r) {
        a.write(r);
        b.write(r);
        ++n;
        if (++in_chunk == 8000 && pattern[k % pattern.size()] > 8000) {  // the cap cut
          expect_counts.push_back(in_chunk);
          in_chunk = 0;
          ++k;
        } else if (in_chunk == pattern[k % pattern.size()]) {
          b.endChunk();
          b.endChunk();  // an empty chunk is never written
          expect_counts.push_back(in_chunk);
          in_chunk = 0;
          ++k;
        }
      });
      if (in_chunk) expect_counts.push_back(in_chunk);
      a.close();
      b.close();
      EXPECT_THROW(b.endChunk(), dw::las::LasError);
    }
    std::FILE* f = std::fopen(lz.c_str(), "rb");
    ASSERT_TRUE(f);
    std::fseek(f, 0, SEEK_END);
    const long size = std::ftell(f);
    {
      const dw::las::LasReader r(lz);
      const dw::las::LazChunks chunks(fileno(f), lz, r.header(), std::uint64_t(size));
      EXPECT_TRUE(chunks.vlr().variableChunks());
      ASSERT_EQ(chunks.size(), expect_counts.size()) << format;
      for (std::size_t c = 0; c < chunks.size(); ++c) ASSERT_EQ(chunks.points(c), expect_counts[c]) << c;
    }
    std::fclose(f);
    dw::las::LasReader ra(las), rb(lz);
    for (std::uint64_t at :
         {std::uint64_t(0), std::uint64_t(5001), std::uint64_t(13001), std::uint64_t(39999)}) {
      ra.seek(at);
      rb.seek(at);
      std::vector<LasRecord> va, vb;
      ASSERT_EQ(ra.read(va, 9000), rb.read(vb, 9000));
      for (std::size_t i = 0; i < va.size(); ++i) {
        ASSERT_EQ(std::memcmp(&va[i].X, &vb[i].X, 12), 0) << format << " " << at + i;
        ASSERT_EQ(va[i].gps_time, vb[i].gps_time);
        ASSERT_EQ(va[i].classification, vb[i].classification);
      }
    }
    for (unsigned threads : {1u, 3u}) {
      dw::las::LasReadOptions ro;
      ro.threads = threads;
      ro.classification = 2;
      const auto ca = dw::las::readLasFile(lz, ro), cb = dw::las::readLasFile(las, ro);
      ASSERT_GT(cb.size(), 0u);
      EXPECT_EQ(ca.X, cb.X);
      EXPECT_EQ(ca.Y, cb.Y);
      EXPECT_EQ(ca.Z, cb.Z);
    }
    std::remove(las.c_str());
    std::remove(lz.c_str());
  }
}

TEST(LazRoundTrip, FixedChunksRefuseEndChunkAndBadSizes) {
  dw::las::LasHeader h;
  h.version_minor = 2;
  h.point_format = 1;
  const std::string lz = tmpPath("fixed.laz");
  {
    dw::las::LazWriter w(lz, h, 0, 100);
    EXPECT_THROW(w.endChunk(), dw::las::LasError);
  }
  EXPECT_THROW(dw::las::LazWriter(lz, h, 0, (1u << 24) + 1), dw::las::LasError);
  std::remove(lz.c_str());
}

}  // namespace
