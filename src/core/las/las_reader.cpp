/// \file las_reader.cpp
/// \brief LAS header validation and chunked record reading.
#include "pcl_delaunay_walk/core/las/las_reader.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>

#include "core/las/laz_reader.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace las {
namespace {

template <typename T>
T get(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

std::string fixedString(const unsigned char* p, std::size_t n) {
  std::string s(reinterpret_cast<const char*>(p), n);
  const auto z = s.find('\0');
  if (z != std::string::npos) s.resize(z);
  return s;
}

}  // namespace

namespace {

/// parseHeader's checks; a LAZ header (compressed marker) is accepted only with `allow_laz`, and its
/// point count is then checked against the chunk table instead of the file size.
LasHeader parseAnyHeader(const unsigned char* b, std::size_t available, std::uint64_t file_size,
                         const std::string& name, bool allow_laz) {
  if (available < 227)
    throw LasError(name + ": file is too short for a LAS header (" + std::to_string(file_size) + " bytes)");
  if (std::memcmp(b, "LASF", 4) != 0) throw LasError(name + ": not a LAS file (signature is not 'LASF')");
  LasHeader h;
  h.version_major = b[24];
  h.version_minor = b[25];
  if (h.version_major != 1 || h.version_minor > 4)
    throw LasError(name + ": unsupported LAS version " + std::to_string(h.version_major) + "." +
                   std::to_string(h.version_minor) + " (supported: 1.0 to 1.4)");
  h.system_id = fixedString(b + 26, 32);
  h.software = fixedString(b + 58, 32);
  h.header_size = get<std::uint16_t>(b + 94);
  h.offset_to_points = get<std::uint32_t>(b + 96);
  h.num_vlrs = get<std::uint32_t>(b + 100);
  const std::uint8_t raw_format = b[104];
  h.record_length = get<std::uint16_t>(b + 105);
  const std::uint32_t legacy_count = get<std::uint32_t>(b + 107);
  for (int k = 0; k < 3; ++k) {
    h.scale[k] = get<double>(b + 131 + 8 * k);
    h.offset[k] = get<double>(b + 155 + 8 * k);
    h.max[k] = get<double>(b + 179 + 16 * k);
    h.min[k] = get<double>(b + 187 + 16 * k);
  }
  // LASzip marks compressed data by setting the top bits of the point format; the record length and
  // count stay those of the uncompressed records, checked against the chunk table by the reader.
  const bool compressed = (raw_format & 0xC0) != 0;
  if (compressed && !allow_laz)
    throw LasError(name +
                   ": this is a LAZ (LASzip-compressed) header; parseHeader reads uncompressed "
                   "headers, LasReader and readLasFile read LAZ files");
  h.point_format = raw_format & 0x3F;
  const std::size_t min_header = h.version_minor >= 4 ? 375 : (h.version_minor == 3 ? 235 : 227);
  if (h.header_size < min_header)
    throw LasError(name + ": header size " + std::to_string(h.header_size) + " is smaller than LAS 1." +
                   std::to_string(h.version_minor) + " requires (" + std::to_string(min_header) + ")");
  if (h.point_format > 10)
    throw LasError(name + ": unsupported point data record format " + std::to_string(h.point_format) +
                   " (supported: 0 to 10)");
  if (h.point_format >= 6 && h.version_minor < 4)
    throw LasError(name + ": point format " + std::to_string(h.point_format) +
                   " requires LAS 1.4, file says 1." + std::to_string(h.version_minor));
  if (h.record_length < baseRecordSize(h.point_format))
    throw LasError(name + ": point record length " + std::to_string(h.record_length) +
                   " is shorter than format " + std::to_string(h.point_format) + " needs (" +
                   std::to_string(baseRecordSize(h.point_format)) + ")");
  if (h.offset_to_points < h.header_size)
    throw LasError(name + ": point data offset " + std::to_string(h.offset_to_points) +
                   " lies inside the header");
  h.point_count = legacy_count;
  if (h.version_minor >= 4) {
    if (available < 375) throw LasError(name + ": truncated LAS 1.4 header");
    const std::uint64_t count64 = get<std::uint64_t>(b + 247);
    if (legacy_count != 0 && count64 != 0 && count64 != legacy_count)
      throw LasError(name + ": legacy point count " + std::to_string(legacy_count) +
                     " contradicts the 64-bit count " + std::to_string(count64));
    if (count64 != 0) h.point_count = count64;
  }
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(h.scale[k]) || h.scale[k] == 0.0 || !std::isfinite(h.offset[k]))
      throw LasError(name + ": invalid scale or offset in the header");
  // Compare counts, not byte sizes: count * record_length can overflow 64 bits on a lying header.
  const std::uint64_t room =
      file_size > h.offset_to_points ? (file_size - h.offset_to_points) / h.record_length : 0;
  if (!compressed && h.point_count > room)
    throw LasError(name + ": file is truncated: the header announces " + std::to_string(h.point_count) +
                   " points of " + std::to_string(h.record_length) + " bytes after offset " +
                   std::to_string(h.offset_to_points) + ", but the file has " + std::to_string(file_size) +
                   " bytes (room for " + std::to_string(room) + " points)");
  return h;
}

}  // namespace

LasHeader parseHeader(const unsigned char* b, std::size_t available, std::uint64_t file_size,
                      const std::string& name) {
  return parseAnyHeader(b, available, file_size, name, false);
}

LasReader::LasReader(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_) throw LasError(path + ": cannot open for reading");
  std::fseek(file_, 0, SEEK_END);
  const long size = std::ftell(file_);
  std::fseek(file_, 0, SEEK_SET);
  unsigned char head[375] = {0};
  const std::size_t got = std::fread(head, 1, sizeof head, file_);
  try {
    header_ = parseAnyHeader(head, got, size < 0 ? 0 : std::uint64_t(size), path, true);
    if (head[104] & 0xC0) {
      laz_ = std::make_unique<LazChunks>(fileno(file_), path, header_, size < 0 ? 0 : std::uint64_t(size));
      laz_decoder_ = laz_->makeDecoder();
    }
  } catch (...) {
    std::fclose(file_);
    file_ = nullptr;
    throw;
  }
  seek(0);
}

LasReader::~LasReader() {
  if (file_) std::fclose(file_);
}

void LasReader::seek(std::uint64_t index) {
  if (index > header_.point_count) throw LasError(path_ + ": seek past the last point");
  if (laz_) {
    next_ = index;
    return;
  }
  const std::uint64_t pos = header_.offset_to_points + index * header_.record_length;
  if (fseeko(file_, static_cast<off_t>(pos), SEEK_SET) != 0) throw LasError(path_ + ": seek failed");
  next_ = index;
}

std::vector<std::uint64_t> LasReader::chunkStarts() const {
  std::vector<std::uint64_t> starts;
  if (!laz_) return starts;
  starts.reserve(laz_->size());
  for (std::size_t c = 0; c < laz_->size(); ++c) starts.push_back(laz_->firstPoint(c));
  return starts;
}

std::size_t LasReader::read(std::vector<LasRecord>& out, std::size_t max_records) {
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(max_records, remaining()));
  out.resize(n);
  if (n == 0) return 0;
  if (laz_) return readLaz(out, n);
  buffer_.resize(n * header_.record_length);
  const std::size_t got = std::fread(buffer_.data(), 1, buffer_.size(), file_);
  if (got != buffer_.size())
    throw LasError(path_ + ": unexpected end of file at point " +
                   std::to_string(next_ + got / header_.record_length) + " of " +
                   std::to_string(header_.point_count));
  for (std::size_t i = 0; i < n; ++i)
    decodeRecord(buffer_.data() + i * header_.record_length, header_.point_format, out[i]);
  next_ += n;
  return n;
}

std::size_t LasReader::readLaz(std::vector<LasRecord>& out, std::size_t n) {
  std::size_t done = 0;
  while (done < n) {
    const std::size_t c = laz_->chunkOf(next_);
    if (c != laz_chunk_) {
      laz_chunk_ = ~std::size_t(0);  // a failed decode leaves no half chunk behind
      laz_->decode(c, *laz_decoder_, laz_compressed_, buffer_);
      laz_chunk_ = c;
    }
    const std::uint64_t first = laz_->firstPoint(c);
    const std::size_t take = std::size_t(std::min<std::uint64_t>(n - done, first + laz_->points(c) - next_));
    for (std::size_t i = 0; i < take; ++i)
      decodeRecord(buffer_.data() + (next_ - first + i) * header_.record_length, header_.point_format,
                   out[done + i]);
    done += take;
    next_ += take;
  }
  return n;
}

namespace {

/// Keeps record r in the cloud unless the class filter drops it.
inline void appendRecord(const LasRecord& r, const LasReadOptions& options, LasCloud& cloud) {
  if (options.classification >= 0 && r.classification != options.classification) return;
  cloud.X.push_back(r.X);
  cloud.Y.push_back(r.Y);
  cloud.Z.push_back(r.Z);
  if (options.keep_attributes) {
    cloud.classification.push_back(r.classification);
    cloud.intensity.push_back(r.intensity);
    cloud.return_number.push_back(r.return_number);
  }
}

/// The kept records of one decoded chunk as structure-of-arrays (only the arrays the cloud fills).
struct ChunkCloud {
  std::vector<std::int32_t> X, Y, Z;
  std::vector<std::uint8_t> classification, return_number;
  std::vector<std::uint16_t> intensity;
  void convert(const unsigned char* records, std::size_t count, const LasHeader& h,
               const LasReadOptions& options) {
    X.clear(), Y.clear(), Z.clear(), classification.clear(), return_number.clear(), intensity.clear();
    LasRecord r;
    for (std::size_t i = 0; i < count; ++i) {
      decodeRecord(records + i * h.record_length, h.point_format, r);
      if (options.classification >= 0 && r.classification != options.classification) continue;
      X.push_back(r.X);
      Y.push_back(r.Y);
      Z.push_back(r.Z);
      if (options.keep_attributes) {
        classification.push_back(r.classification);
        intensity.push_back(r.intensity);
        return_number.push_back(r.return_number);
      }
    }
  }
};

template <typename T>
void append(std::vector<T>& to, const std::vector<T>& from) {
  to.insert(to.end(), from.begin(), from.end());
}

/// LAZ: batches of a few chunks per thread are decoded and converted to arrays in parallel, then
/// appended in file order (a copy), so the cloud is the same for any thread count and memory beyond
/// the cloud holds one batch: a few chunks' records per thread.
LasCloud readLazFile(const std::string& path, const LasReadOptions& options) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw LasError(path + ": cannot open for reading");
  struct Closer {
    std::FILE* f;
    ~Closer() { std::fclose(f); }
  } closer{f};
  std::fseek(f, 0, SEEK_END);
  const long size = std::ftell(f);
  unsigned char head[375] = {0};
  const ssize_t read_bytes = ::pread(fileno(f), head, sizeof head, 0);
  const std::size_t got = read_bytes > 0 ? std::size_t(read_bytes) : 0;
  LasCloud cloud;
  cloud.header = parseAnyHeader(head, got, std::uint64_t(size), path, true);
  const LasHeader& h = cloud.header;
  const LazChunks chunks(fileno(f), path, h, std::uint64_t(size));
  if (options.classification < 0) {
    cloud.X.reserve(h.point_count);
    cloud.Y.reserve(h.point_count);
    cloud.Z.reserve(h.point_count);
  }
  const unsigned threads = resolveThreads(options.threads);
  // Four chunks per thread keep every thread busy across uneven chunks while a batch's last ones
  // finish; that many chunks' records are the memory the decoding needs beyond the cloud.
  const std::size_t batch = std::size_t(threads) * 4;
  struct Slot {
    std::unique_ptr<laz::ChunkDecoder> decoder;
    std::vector<std::uint8_t> compressed, records;
    ChunkCloud kept;
  };
  std::vector<Slot> slots(std::min(batch, chunks.size()));
  for (auto& s : slots) s.decoder = chunks.makeDecoder();
  for (std::size_t begin = 0; begin < chunks.size(); begin += batch) {
    const std::size_t n = std::min(batch, chunks.size() - begin);
    parallelForDynamic(n, threads, [&](std::size_t i) {
      Slot& s = slots[i];
      chunks.decode(begin + i, *s.decoder, s.compressed, s.records);
      s.kept.convert(s.records.data(), chunks.points(begin + i), h, options);
    });
    for (std::size_t i = 0; i < n; ++i) {
      const ChunkCloud& k = slots[i].kept;
      append(cloud.X, k.X);
      append(cloud.Y, k.Y);
      append(cloud.Z, k.Z);
      append(cloud.classification, k.classification);
      append(cloud.intensity, k.intensity);
      append(cloud.return_number, k.return_number);
    }
    if (options.progress) options.progress(double(begin + n) / double(chunks.size()), options.progress_user);
  }
  return cloud;
}

bool isLaz(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  unsigned char head[105] = {0};
  const bool laz = std::fread(head, 1, sizeof head, f) == sizeof head && std::memcmp(head, "LASF", 4) == 0 &&
                   (head[104] & 0xC0);
  std::fclose(f);
  return laz;
}

}  // namespace

LasCloud readLasFile(const std::string& path, const LasReadOptions& options) {
  if (isLaz(path)) return readLazFile(path, options);
  LasReader reader(path);
  LasCloud cloud;
  cloud.header = reader.header();
  const std::uint64_t total = reader.header().point_count;
  if (options.classification < 0) {
    cloud.X.reserve(total);
    cloud.Y.reserve(total);
    cloud.Z.reserve(total);
  }
  std::vector<LasRecord> chunk;
  std::uint64_t done = 0;
  while (reader.read(chunk, 1 << 16) > 0) {
    for (const LasRecord& r : chunk) {
      appendRecord(r, options, cloud);
    }
    done += chunk.size();
    if (options.progress) options.progress(total ? double(done) / double(total) : 1.0, options.progress_user);
  }
  return cloud;
}

}  // namespace las
}  // namespace dw
