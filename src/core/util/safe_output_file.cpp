/// \file safe_output_file.cpp
/// \brief Temporary-then-rename output files (see safe_output_file.h for what holds).
#include "pcl_delaunay_walk/core/util/safe_output_file.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <mutex>
#include <random>
#include <system_error>
#include <utility>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace {

constexpr char kInfix[] = ".tmp.";
constexpr int kRandomLetters = 6;
constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
/// A temporary younger than this is never taken for a dead writer's: it covers the instant between a
/// live writer's create and its flock, and any clock skew of a shared file system.
constexpr std::time_t kStaleAfterSeconds = 10;

std::string reason(int err) {
  return err != 0 ? std::strerror(err) : "unknown I/O error";
}

/// The folder part ("." when none) and the file name of `path`.
std::pair<std::string, std::string> splitPath(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return {".", path};
  return {slash == 0 ? "/" : path.substr(0, slash), path.substr(slash + 1)};
}

/// ".tif" for "dem.tif", "" for "dem" or ".hidden".
std::string extensionOf(const std::string& name) {
  const std::size_t dot = name.find_last_of('.');
  return dot == std::string::npos || dot == 0 ? std::string() : name.substr(dot);
}

/// The file a write to `target` must replace: a symbolic link is followed (as open(2) would), a
/// dangling one is replaced by the new file.
std::string resolveTarget(const std::string& target) {
  struct stat st;
  if (::lstat(target.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return target;
  char buf[PATH_MAX];
  return ::realpath(target.c_str(), buf) ? std::string(buf) : target;
}

/// True where the target exists and is not a regular file (a device, a FIFO): no rename can replace
/// it, so it is written in place.
bool writtenInPlace(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode);
}

bool isStaleName(const std::string& entry, const std::string& name, const std::string& ext) {
  const std::string head = name + kInfix;
  if (entry.size() < head.size() + kRandomLetters || entry.compare(0, head.size(), head) != 0) return false;
  for (int k = 0; k < kRandomLetters; ++k)
    if (std::strchr(kAlphabet, entry[head.size() + k]) == nullptr) return false;
  const std::string rest = entry.substr(head.size() + kRandomLetters);
  return rest.empty() || (!ext.empty() && rest == ext);
}

/// Removes the temporaries of `name` in `dir` that no living writer holds (see the header).
void removeStaleTemporaries(const std::string& dir, const std::string& name) {
  DIR* d = ::opendir(dir.c_str());
  if (!d) return;
  const std::string ext = extensionOf(name);
  const std::time_t now = std::time(nullptr);
  while (const dirent* e = ::readdir(d)) {
    if (!isStaleName(e->d_name, name, ext)) continue;
    const int fd = ::openat(::dirfd(d), e->d_name, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) continue;
    struct stat st;
    if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_mtime + kStaleAfterSeconds < now &&
        ::flock(fd, LOCK_EX | LOCK_NB) == 0)
      ::unlinkat(::dirfd(d), e->d_name, 0);
    ::close(fd);
  }
  ::closedir(d);
}

/// Creates `<final>.tmp.XXXXXX<suffix>` exclusively, with the permissions the target would get
/// (mode 0666 through the umask, or the existing target's bits), locked; returns its fd and path.
/// Not mkstemp: that one creates mode 0600 whatever the umask, and reading the umask back is racy.
std::pair<int, std::string> createTemporary(const std::string& target, const std::string& final_path,
                                            const std::string& suffix) {
  const auto [dir, name] = splitPath(final_path);
  removeStaleTemporaries(dir, name);
  std::random_device entropy;
  std::mt19937_64 rng((std::uint64_t(entropy()) << 32) ^ entropy() ^ std::uint64_t(::getpid()));
  std::uniform_int_distribution<int> letter(0, int(sizeof(kAlphabet)) - 2);
  int err = 0;
  for (int attempt = 0; attempt < 100; ++attempt) {
    std::string path = final_path + kInfix;
    for (int k = 0; k < kRandomLetters; ++k) path += kAlphabet[letter(rng)];
    path += suffix;
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
      err = errno;
      if (err == EEXIST) continue;
      break;
    }
    struct stat st;
    if (::stat(final_path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) ::fchmod(fd, st.st_mode & 07777);
    ::flock(fd, LOCK_EX | LOCK_NB);  // best effort: where the file system has no locks, age alone guards
    return {fd, path};
  }
  throw Error(target + ": cannot create a temporary file in '" + dir + "': " + reason(err));
}

/// fsync of a folder after a rename in it: best effort (see the header).
void syncFolder(const std::string& path) {
  const int fd = ::open(splitPath(path).first.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

/// The temporaries handed out by temporaryPathFor, with the descriptor that holds each one's lock.
struct LockedTemporaries {
  std::mutex mutex;
  std::map<std::string, int> fds;

  void add(const std::string& path, int fd) {
    std::lock_guard<std::mutex> lock(mutex);
    fds[path] = fd;
  }
  /// The descriptor of `path` (-1 if not ours); the entry is removed.
  int take(const std::string& path) {
    std::lock_guard<std::mutex> lock(mutex);
    const auto it = fds.find(path);
    if (it == fds.end()) return -1;
    const int fd = it->second;
    fds.erase(it);
    return fd;
  }
};

LockedTemporaries& lockedTemporaries() {
  static LockedTemporaries* registry = new LockedTemporaries();  // never destroyed: no exit-order issue
  return *registry;
}

}  // namespace

SafeOutputFile::SafeOutputFile(const std::string& target) {
  open(target);
}

SafeOutputFile::~SafeOutputFile() {
  discard();
}

SafeOutputFile::SafeOutputFile(SafeOutputFile&& o) noexcept
    : target_(std::move(o.target_)),
      final_(std::move(o.final_)),
      temporary_(std::move(o.temporary_)),
      file_(std::exchange(o.file_, nullptr)) {}

SafeOutputFile& SafeOutputFile::operator=(SafeOutputFile&& o) noexcept {
  if (this != &o) {
    discard();
    target_ = std::move(o.target_);
    final_ = std::move(o.final_);
    temporary_ = std::move(o.temporary_);
    file_ = std::exchange(o.file_, nullptr);
  }
  return *this;
}

void SafeOutputFile::open(const std::string& target) {
  discard();
  if (target.empty()) throw Error("cannot write a file with an empty name");
  target_ = target;
  final_ = resolveTarget(target);
  temporary_.clear();
  if (writtenInPlace(final_)) {
    file_ = std::fopen(final_.c_str(), "wb");
    if (!file_) throw Error(target + ": cannot open for writing: " + reason(errno));
    return;
  }
  auto [fd, path] = createTemporary(target, final_, "");
  file_ = ::fdopen(fd, "w+b");
  if (!file_) {
    const int err = errno;
    ::close(fd);
    ::unlink(path.c_str());
    throw Error(target + ": cannot open a temporary file: " + reason(err));
  }
  temporary_ = std::move(path);
}

void SafeOutputFile::fail(const char* what, int err) {
  discard();
  throw Error(target_ + ": " + what + ": " + reason(err));
}

void SafeOutputFile::write(const void* data, std::size_t n) {
  if (!file_) throw Error(target_ + ": write to a file that is not open (an earlier write failed?)");
  if (n != 0 && std::fwrite(data, 1, n, file_) != n) fail("write failed", errno);
}

void SafeOutputFile::seek(std::uint64_t offset) {
  if (!file_) throw Error(target_ + ": seek in a file that is not open");
  if (offset > std::uint64_t(LLONG_MAX) || ::fseeko(file_, off_t(offset), SEEK_SET) != 0)
    fail("seek failed", errno);
}

void SafeOutputFile::seekToEnd() {
  if (!file_) throw Error(target_ + ": seek in a file that is not open");
  if (::fseeko(file_, 0, SEEK_END) != 0) fail("seek failed", errno);
}

std::uint64_t SafeOutputFile::tell() {
  if (!file_) throw Error(target_ + ": tell in a file that is not open");
  const off_t at = ::ftello(file_);
  if (at < 0) fail("tell failed", errno);
  return std::uint64_t(at);
}

void SafeOutputFile::commit() {
  if (!file_) throw Error(target_ + ": commit of a file that is not open (an earlier write failed?)");
  errno = 0;
  if (std::fflush(file_) != 0 || std::ferror(file_)) fail("write failed", errno);
  const int fd = ::fileno(file_);
  // A device or FIFO written in place may refuse fsync (EINVAL); that is no lost data.
  if (::fsync(fd) != 0 && !(temporary_.empty() && (errno == EINVAL || errno == EROFS)))
    fail("fsync failed", errno);
  // The duplicate keeps the temporary's lock (it belongs to the open file) until the rename is done.
  const int keep = temporary_.empty() ? -1 : ::dup(fd);
  std::FILE* f = std::exchange(file_, nullptr);
  if (std::fclose(f) != 0) {
    const int err = errno;
    if (keep >= 0) ::close(keep);
    if (!temporary_.empty()) ::unlink(temporary_.c_str());
    throw Error(target_ + ": close failed: " + reason(err));
  }
  if (temporary_.empty()) return;
  if (::rename(temporary_.c_str(), final_.c_str()) != 0) {
    const int err = errno;
    ::unlink(temporary_.c_str());
    if (keep >= 0) ::close(keep);
    throw Error(target_ + ": cannot replace it with the finished temporary: " + reason(err));
  }
  if (keep >= 0) ::close(keep);
  syncFolder(final_);
  temporary_.clear();
}

void SafeOutputFile::discard() noexcept {
  if (file_) std::fclose(file_);
  file_ = nullptr;
  if (!temporary_.empty()) ::unlink(temporary_.c_str());
  temporary_.clear();
}

std::string temporaryPathFor(const std::string& target) {
  if (target.empty()) throw Error("cannot write a file with an empty name");
  const std::string final_path = resolveTarget(target);
  if (writtenInPlace(final_path)) return target;
  auto [fd, path] = createTemporary(target, final_path, extensionOf(splitPath(final_path).second));
  lockedTemporaries().add(path, fd);
  return path;
}

void commitTemporary(const std::string& temporary, const std::string& target) {
  const std::string final_path = resolveTarget(target);
  const int lock_fd = lockedTemporaries().take(temporary);
  auto failWith = [&](const std::string& what, int err) {
    if (temporary != target) ::unlink(temporary.c_str());
    if (lock_fd >= 0) ::close(lock_fd);
    throw Error(target + ": " + what + ": " + reason(err));
  };
  if (temporary == target) {
    struct stat st;
    if (::stat(target.c_str(), &st) != 0) failWith("not written", errno);
    return;
  }
  const int fd = ::open(temporary.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) failWith("the temporary '" + temporary + "' cannot be opened", errno);
  struct stat st {};
  errno = 0;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size == 0) {
    const int err = errno;
    ::close(fd);
    failWith("the temporary '" + temporary + "' is empty or not a file (the writer failed)",
             st.st_size == 0 ? EIO : err);
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    failWith("fsync failed", err);
  }
  ::close(fd);
  if (::rename(temporary.c_str(), final_path.c_str()) != 0)
    failWith("cannot replace it with the finished temporary", errno);
  if (lock_fd >= 0) ::close(lock_fd);
  syncFolder(final_path);
}

void discardTemporary(const std::string& temporary) noexcept {
  const int fd = lockedTemporaries().take(temporary);
  if (fd < 0) return;  // not ours (or the target itself, written in place): leave it
  ::unlink(temporary.c_str());
  ::close(fd);
}

}  // namespace dw
