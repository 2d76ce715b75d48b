#include "pcl_delaunay_walk/core/graph/graph_io.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>

#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"

namespace dw {

namespace {

constexpr char kMagic[8] = {'D', 'W', 'G', 'R', 'A', 'P', 'H', '\0'};

/// Fixed-size little-endian header. Every field is covered by header_checksum, the arrays by
/// payload_checksum; sizes are checked against the file size before anything is allocated.
struct Header {
  char magic[8];
  std::uint32_t version;
  std::uint32_t header_size;
  std::uint32_t dimension;
  std::uint32_t flags;
  std::uint64_t num_vertices;
  std::uint64_t num_edges;
  std::uint64_t num_input;
  std::uint64_t num_originals;
  double origin[3];
  std::uint64_t payload_bytes;
  std::uint64_t payload_checksum;
  std::uint64_t header_checksum;  ///< over all bytes before this field
};
static_assert(sizeof(Header) == 104, "header layout");

/// 64-bit word-wise hash (multiply-xorshift): ~memory speed, and any byte flip changes it.
std::uint64_t checksumImpl(const std::uint8_t* p, std::size_t n) {
  std::uint64_t h = 0x9E3779B97F4A7C15ULL ^ n;
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, p + i, 8);
    h = (h ^ w) * 0xff51afd7ed558ccdULL;
    h ^= h >> 29;
  }
  for (; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ULL;
  h ^= h >> 33;
  h *= 0xc4ceb9fe1a85ec53ULL;
  return h ^ (h >> 33);
}

/// Version 2's payload checksum: checksumImpl of every 1 MiB block, then checksumImpl of those block
/// hashes and the length. The blocks are independent, so all threads verify a large map at once;
/// version 1's single chain runs on one.
constexpr std::size_t kChecksumBlock = std::size_t(1) << 20;

std::uint64_t blockedChecksum(const std::uint8_t* p, std::size_t n) {
  const std::size_t blocks = (n + kChecksumBlock - 1) / kChecksumBlock;
  std::vector<std::uint64_t> hashes(blocks + 1);
  parallelFor(blocks, workerCount(blocks, 0, 8), [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t k = b; k < e; ++k) {
      const std::size_t at = k * kChecksumBlock;
      hashes[k] = checksumImpl(p + at, std::min(kChecksumBlock, n - at));
    }
  });
  hashes[blocks] = n;
  return checksumImpl(reinterpret_cast<const std::uint8_t*>(hashes.data()), hashes.size() * 8);
}

/// The payload checksum of a file of `version` (1 or 2).
std::uint64_t payloadChecksum(std::uint32_t version, const std::uint8_t* p, std::size_t n) {
  return version == 1 ? checksumImpl(p, n) : blockedChecksum(p, n);
}

[[noreturn]] void fail(const std::string& why) {
  throw GraphFileError("pcl_delaunay_walk: bad graph file: " + why);
}

/// a * b + acc without overflow, or fail.
std::uint64_t mulAdd(std::uint64_t a, std::uint64_t b, std::uint64_t acc) {
  if (b != 0 && a > (std::numeric_limits<std::uint64_t>::max() - acc) / b) fail("sizes overflow");
  return acc + a * b;
}

template <typename Array>
void appendArray(std::vector<std::uint8_t>& out, const Array& v) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(v.data());
  out.insert(out.end(), p, p + v.size() * sizeof(v[0]));
}

template <typename T, typename A>
void readArray(const std::uint8_t*& p, std::vector<T, A>& v, std::uint64_t count) {
  v.resize(count);
  if (count != 0) std::memcpy(v.data(), p, count * sizeof(T));  // memcpy(nullptr, ., 0) is UB
  p += count * sizeof(T);
}

}  // namespace

std::uint64_t graphFileChecksum(const std::uint8_t* data, std::size_t n) {
  return checksumImpl(data, n);
}

void resealGraphFile(std::vector<std::uint8_t>& f) {
  if (f.size() < sizeof(Header)) return;
  std::uint32_t version;
  std::memcpy(&version, f.data() + offsetof(Header, version), 4);
  const std::uint64_t payload =
      payloadChecksum(version, f.data() + sizeof(Header), f.size() - sizeof(Header));
  std::memcpy(f.data() + offsetof(Header, payload_checksum), &payload, 8);
  const std::uint64_t header = checksumImpl(f.data(), offsetof(Header, header_checksum));
  std::memcpy(f.data() + offsetof(Header, header_checksum), &header, 8);
}

std::vector<std::uint8_t> serializeGraph(const DelaunayGraph& g) {
  Header h{};
  std::memcpy(h.magic, kMagic, 8);
  h.version = kGraphFileVersion;
  h.header_size = sizeof(Header);
  h.dimension = static_cast<std::uint32_t>(g.dimension);
  h.num_vertices = g.points.size();
  h.num_edges = g.edges.size();
  h.num_input = g.input_to_vertex.size();
  h.num_originals = g.originals.size();
  for (int a = 0; a < 3; ++a) h.origin[a] = g.origin[a];
  std::vector<std::uint8_t> out(sizeof(Header));
  appendArray(out, g.points);
  appendArray(out, g.offsets);
  appendArray(out, g.edges);
  appendArray(out, g.input_to_vertex);
  appendArray(out, g.originals_offsets);
  appendArray(out, g.originals);
  h.payload_bytes = out.size() - sizeof(Header);
  h.payload_checksum = payloadChecksum(h.version, out.data() + sizeof(Header), h.payload_bytes);
  h.header_checksum =
      checksumImpl(reinterpret_cast<const std::uint8_t*>(&h), offsetof(Header, header_checksum));
  std::memcpy(out.data(), &h, sizeof(Header));
  return out;
}

void saveGraph(const DelaunayGraph& g, const std::string& path) {
  const auto bytes = serializeGraph(g);
  try {
    SafeOutputFile f(path);  // an existing file stays until the new one is complete (the rename)
    f.write(bytes.data(), bytes.size());
    f.commit();
  } catch (const Error& e) {
    throw Error(std::string("pcl_delaunay_walk: saving the graph failed: ") + e.what());
  }
}

namespace {

/// A private, writable (copy-on-write) mapping of a whole file, unmapped when the last owner goes.
/// Writable so that a graph whose edge records view it can be edited like a built one: the kernel
/// copies the pages written, the file never changes. The file must not be truncated or rewritten in
/// place while mapped (a page past a new end would fault, a rewritten one could break the checked
/// invariants); saveGraph replaces files by rename, which leaves a mapping of the old file intact.
class MappedFile {
 public:
  explicit MappedFile(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw GraphFileError("pcl_delaunay_walk: cannot open graph file '" + path + "'");
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
      ::close(fd);
      throw GraphFileError("pcl_delaunay_walk: cannot open graph file '" + path + "': not a regular file");
    }
    size_ = static_cast<std::size_t>(st.st_size);
    if (size_ > 0) {
      void* p = ::mmap(nullptr, size_, PROT_READ | PROT_WRITE, MAP_PRIVATE, fd, 0);
      if (p == MAP_FAILED) {
        ::close(fd);
        throw GraphFileError("pcl_delaunay_walk: cannot map graph file '" + path + "'");
      }
      ::madvise(p, size_, MADV_SEQUENTIAL);  // the checks read it once, front to back
      data_ = static_cast<std::uint8_t*>(p);
    }
    ::close(fd);  // the mapping keeps the file (also once its path is removed or renamed)
  }
  ~MappedFile() {
    if (data_) ::munmap(data_, size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  std::uint8_t* data() const { return data_; }
  std::size_t size() const { return size_; }
  /// After the checks: the walk's reads are random, and pages should not age as read-once.
  void accessRandomly() const {
    if (data_) ::madvise(data_, size_, MADV_NORMAL);
  }

 private:
  std::uint8_t* data_ = nullptr;
  std::size_t size_ = 0;
};

/// The header checked against the buffer's size and checksums; returns it.
Header checkedHeader(const std::uint8_t* data, std::size_t size) {
  if (size < sizeof(Header)) fail("shorter than its header (" + std::to_string(size) + " bytes)");
  Header h;
  std::memcpy(&h, data, sizeof(Header));
  if (std::memcmp(h.magic, kMagic, 8) != 0) fail("not a pcl_delaunay_walk graph (magic mismatch)");
  if (h.header_checksum != checksumImpl(data, offsetof(Header, header_checksum)))
    fail("header checksum mismatch");
  if (h.version < kOldestGraphFileVersion || h.version > kGraphFileVersion)
    fail("version " + std::to_string(h.version) + " is not supported (this build reads versions " +
         std::to_string(kOldestGraphFileVersion) + " to " + std::to_string(kGraphFileVersion) + ")");
  if (h.header_size != sizeof(Header) || h.dimension > 3) fail("malformed header");
  if (h.flags != 0)
    fail("unknown feature flags " + std::to_string(h.flags) + " for version " + std::to_string(h.version));
  std::uint64_t expect = 0;
  expect = mulAdd(h.num_vertices, sizeof(Vec3f), expect);
  expect = mulAdd(h.num_vertices + 1, 2 * sizeof(index_t), expect);
  expect = mulAdd(h.num_edges, sizeof(EdgeRecord), expect);
  expect = mulAdd(h.num_input, sizeof(index_t), expect);
  expect = mulAdd(h.num_originals, sizeof(index_t), expect);
  if (h.num_vertices >= kInvalidIndex || h.num_input >= kInvalidIndex || h.num_edges >= kInvalidIndex)
    fail("counts exceed 32-bit indices");
  if (expect != h.payload_bytes || size - sizeof(Header) != h.payload_bytes)
    fail("truncated or padded: payload is " + std::to_string(size - sizeof(Header)) + " bytes, header says " +
         std::to_string(h.payload_bytes) + ", arrays need " + std::to_string(expect));
  if (h.payload_checksum != payloadChecksum(h.version, data + sizeof(Header), h.payload_bytes))
    fail("payload checksum mismatch (corrupt file)");
  return h;
}

/// Parses a checked buffer. With `file` (whose mapping holds the buffer) the edge records are a view
/// of it: the header (104 bytes) and every array before them are whole 4-byte words, so the records
/// start 4-byte aligned in a page-aligned mapping, as EdgeRecord needs. Otherwise they are copied.
DelaunayGraph parseGraph(const std::uint8_t* data, std::size_t size,
                         const std::shared_ptr<MappedFile>& file) {
  const Header h = checkedHeader(data, size);
  const std::uint8_t* p = data + sizeof(Header);
  DelaunayGraph g;
  g.dimension = static_cast<int>(h.dimension);
  for (int a = 0; a < 3; ++a) g.origin[a] = h.origin[a];
  readArray(p, g.points, h.num_vertices);
  readArray(p, g.offsets, h.num_vertices + 1);
  const bool view = file && reinterpret_cast<std::uintptr_t>(p) % alignof(EdgeRecord) == 0;
  if (view) {
    auto* records = reinterpret_cast<EdgeRecord*>(file->data() + (p - data));
    g.edges = EdgeRecords::view(records, h.num_edges, file);
    p += h.num_edges * sizeof(EdgeRecord);
  } else {
    g.edges.resize(h.num_edges);
    if (h.num_edges != 0) std::memcpy(g.edges.data(), p, h.num_edges * sizeof(EdgeRecord));
    p += h.num_edges * sizeof(EdgeRecord);
  }
  readArray(p, g.input_to_vertex, h.num_input);
  readArray(p, g.originals_offsets, h.num_vertices + 1);
  readArray(p, g.originals, h.num_originals);
  // Files whose neighbourhoods are not shortest-first (same format otherwise) are sorted; a mapped
  // file's sorted neighbourhoods are only read, so their pages stay the file's.
  // The checks below and the payload checksum run on all hardware threads: a 10M-point map is ~3 GB.
  sortNeighbourhoods(g, 0);
  try {
    g.validate(0);  // one pass per array: every index the walk follows is checked in range
  } catch (const Error& e) {
    fail(e.what());
  }
  computeSafeRadii(g, 0);  // derived data: recomputed (O(E)) rather than trusted from the file
  if (view) file->accessRandomly();
  return g;
}

}  // namespace

DelaunayGraph deserializeGraph(const std::uint8_t* data, std::size_t size) {
  return parseGraph(data, size, nullptr);
}

DelaunayGraph loadGraph(const std::string& path, GraphStorage storage) {
  const auto file = std::make_shared<MappedFile>(path);
  // A file of 0 bytes maps to nothing; the parser reports it as shorter than its header.
  static const std::uint8_t kNothing = 0;
  try {
    return parseGraph(file->data() ? file->data() : &kNothing, file->size(),
                      storage == GraphStorage::Mapped ? file : nullptr);
  } catch (const GraphFileError& e) {
    throw GraphFileError(std::string(e.what()) + " ('" + path + "')");
  }
}

}  // namespace dw
