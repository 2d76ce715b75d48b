/// \file safe_output_file.h
/// \brief Output files that are never half written: every file the module writes goes to a temporary
/// in the target's folder and is renamed over the target only once it is complete and on disk.
///
/// What holds, for every writer built on this (graph files, PLY meshes, LAS/LAZ, the MPI pieces and
/// manifests, the apps' outputs):
/// - Until commit() returns, the target is untouched: an existing file stays byte for byte, a missing
///   one stays missing. A failure anywhere (a short write, `EFBIG` under `RLIMIT_FSIZE`, `ENOSPC`, a
///   failed fflush, fsync or close, a failed rename) throws dw::Error naming the target and the reason
///   (`strerror`: "File too large", "No space left on device", "Permission denied") and removes the
///   temporary.
/// - commit() = fflush + fsync + fclose, each checked, then rename(2) over the target (atomic within a
///   file system: a reader sees the old file or the new one, never a mix), then a best-effort fsync of
///   the folder (after the rename nothing can be undone, so a folder that refuses fsync is not an error).
/// - The temporary is `<target>.tmp.XXXXXX` (six random letters or digits) in the target's folder, so
///   the rename never crosses file systems. It is created with mode 0666 minus the umask, as a fresh
///   target would be; when the target already exists its permission bits are kept, as overwriting it in
///   place kept them. A symbolic link as target is followed: the file it names is replaced.
/// - Targets that are not regular files (`/dev/null`, `/dev/stdout`, a FIFO) cannot be replaced by a
///   rename; they are written in place, with every write still checked.
///
/// A process killed between creating the temporary and the rename (SIGKILL, power loss) leaves the
/// target as it was plus a stray `<target>.tmp.XXXXXX`. Each writer holds an advisory lock (flock) on
/// its temporary while it lives, and the kernel drops it when the process dies; so the next open() of
/// the same target removes every unlocked temporary of that target older than ten seconds (the age
/// guards the instant between a live writer's create and lock). By hand, with no writer running:
/// `find DIR -regextype posix-extended -regex '.*\.tmp\.[A-Za-z0-9]{6}(\.[^./]+)?' -mmin +10 -delete`.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace dw {

class SafeOutputFile {
 public:
  SafeOutputFile() = default;
  /// open(target).
  explicit SafeOutputFile(const std::string& target);
  /// Without commit(): discard() (the temporary is removed, the target untouched).
  ~SafeOutputFile();
  SafeOutputFile(SafeOutputFile&& other) noexcept;
  SafeOutputFile& operator=(SafeOutputFile&& other) noexcept;
  SafeOutputFile(const SafeOutputFile&) = delete;
  SafeOutputFile& operator=(const SafeOutputFile&) = delete;

  /// Creates the temporary for `target` (removing stale ones of earlier, dead writers). Throws
  /// dw::Error naming the target, the folder and the reason when the folder refuses a new file.
  void open(const std::string& target);
  bool isOpen() const { return file_ != nullptr; }
  /// The path given to open() and the temporary being written (empty when writing in place).
  const std::string& target() const { return target_; }
  const std::string& temporaryPath() const { return temporary_; }

  /// Writes n bytes at the current position; throws dw::Error ("<target>: write failed: <reason>").
  void write(const void* data, std::size_t n);
  /// Moves the write position to `offset` from the start (writers that patch their header last).
  void seek(std::uint64_t offset);
  /// Moves the write position to the end.
  void seekToEnd();
  std::uint64_t tell();
  /// The stdio stream, for code that formats with fprintf. A failure there is caught by commit()
  /// (ferror), with the reason errno held at that point.
  std::FILE* stream() { return file_; }

  /// Makes the written bytes the target (see the file comment). On any failure the temporary is
  /// removed, the target is untouched, and dw::Error names the target and the reason.
  void commit();
  /// Closes and removes the temporary; the target stays as it was. Never throws; no-op when closed.
  void discard() noexcept;

 private:
  [[noreturn]] void fail(const char* what, int err);
  std::string target_;     ///< as given (messages name it)
  std::string final_;      ///< where the rename goes: the target, symbolic links followed
  std::string temporary_;  ///< empty: writing in place (not a regular file)
  std::FILE* file_ = nullptr;
};

/// For code that must write through a library that takes a path (GDAL, VTK's image writers): creates
/// an empty, locked temporary `<target>.tmp.XXXXXX<ext>` (ext: the target's extension, since such
/// libraries pick the format by it) in the target's folder, with the permissions open() would give,
/// and returns its path. Hand that path to the library, let it write and close the file, then call
/// commitTemporary(path, target), or discardTemporary(path) on failure:
/// \code
///   const std::string tmp = dw::temporaryPathFor("dem.tif");
///   try {
///     writeWithGdal(tmp);                      // the library creates/truncates and writes tmp
///     dw::commitTemporary(tmp, "dem.tif");     // fsync, rename over dem.tif, fsync of the folder
///   } catch (...) {
///     dw::discardTemporary(tmp);
///     throw;
///   }
/// \endcode
/// The library must write the file in place (not unlink and recreate it) for the lock to keep
/// concurrent cleaners away while it writes. A target that is not a regular file gets back its own
/// path, and commitTemporary then only checks that it exists.
std::string temporaryPathFor(const std::string& target);
/// fsync of `temporary` (checked) then rename over `target`; on failure removes the temporary and
/// throws dw::Error naming the target and the reason. An empty temporary file is an error (a library
/// that failed without saying so), since replacing a target by nothing is never intended.
void commitTemporary(const std::string& temporary, const std::string& target);
/// Removes a temporary from temporaryPathFor and releases its lock. Never throws.
void discardTemporary(const std::string& temporary) noexcept;

}  // namespace dw
