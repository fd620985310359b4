// Atomic output: every file and directory organsim writes appears complete or
// not at all. Each output is written under a unique temporary name in the
// target's own directory (so that rename stays within one file system), flushed
// to disk (fsync of the file, and of the directory after the rename, so that a
// crash or power loss never publishes a name without its contents), then
// renamed over the target. An output that is never committed is removed.
//
// One home for this rule: the model file, the pipeline's images, meshes and
// intermediates, the DICOM series writer, session and forces files, and the
// viewer's screenshots and recordings all go through here.
//
// Standard library and POSIX only; not for the real-time loops (it does I/O).
#pragma once

#include <cstddef>
#include <string>

namespace organsim::io {

/// Writes `size` bytes to `path` atomically. Throws std::runtime_error naming
/// the path, the failing step and what to check; no file is left behind then,
/// and an existing file at `path` is untouched.
void write_file_atomically(const std::string& path, const void* bytes, std::size_t size);

/// Same, for text.
void write_file_atomically(const std::string& path, const std::string& text);

/// For writers that insist on a file name (ITK, VTK, OpenCV): a unique, empty
/// temporary file next to `path`, ending in `extension` (those libraries pick
/// the format by extension, e.g. ".nii.gz"). The writer fills temp_path();
/// commit() flushes it and renames it over `path`. The destructor removes the
/// temporary file unless it was committed.
class AtomicFile {
 public:
  /// Throws std::runtime_error when the directory of `path` is not writable.
  AtomicFile(const std::string& path, const std::string& extension);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();

  const std::string& temp_path() const noexcept { return temp_; }
  const std::string& path() const noexcept { return path_; }
  /// Flushes the temporary file and renames it over `path`. Throws
  /// std::runtime_error (the temporary file is then removed).
  void commit();

 private:
  std::string path_;
  std::string temp_;
};

/// For outputs written as they are produced (forces, frame indexes of a long
/// session), so that memory stays bounded: appends go to a temporary file next
/// to `path` through a fixed buffer, and commit() publishes it. A failed write
/// (disk full, file size limit) throws std::runtime_error at once, naming the
/// path and the reason; the destructor removes an uncommitted temporary file.
class AtomicStream {
 public:
  explicit AtomicStream(const std::string& path);
  AtomicStream(const AtomicStream&) = delete;
  AtomicStream& operator=(const AtomicStream&) = delete;
  ~AtomicStream();

  void append(const char* bytes, std::size_t size);
  void append(const std::string& text) { append(text.data(), text.size()); }
  /// Bytes appended so far.
  std::size_t size() const noexcept { return written_ + buffered_; }
  const std::string& path() const noexcept { return path_; }
  /// Writes what is buffered, flushes the file and renames it over `path`.
  void commit();

 private:
  void flush_buffer();
  std::string path_;
  std::string temp_;
  int fd_ = -1;
  std::string buffer_;
  std::size_t buffered_ = 0, written_ = 0;
};

/// The same for a whole directory (a DICOM series, a bake's intermediates): a
/// unique, empty temporary directory next to `path`, filled by the caller, and
/// renamed over `path` by commit(), which must then be missing or empty. The
/// destructor removes the temporary directory and everything in it unless it
/// was committed.
class AtomicDirectory {
 public:
  explicit AtomicDirectory(const std::string& path);
  AtomicDirectory(const AtomicDirectory&) = delete;
  AtomicDirectory& operator=(const AtomicDirectory&) = delete;
  ~AtomicDirectory();

  const std::string& temp_path() const noexcept { return temp_; }
  const std::string& path() const noexcept { return path_; }
  /// Flushes every file in the temporary directory and renames it over `path`.
  void commit();

 private:
  std::string path_;
  std::string temp_;
};

/// Flushes an existing file or directory to disk (fsync). Throws
/// std::runtime_error naming the path.
void sync_path(const std::string& path);

}  // namespace organsim::io
