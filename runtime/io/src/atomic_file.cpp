#include "organsim/io/atomic_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace organsim::io {
namespace {

namespace fs = std::filesystem;

std::runtime_error failure(const std::string& path, const std::string& step, int error) {
  return std::runtime_error("cannot write '" + path + "': " + step + " (" + std::strerror(error) +
                            "); check that the directory exists, is writable and has free space");
}

/// The directory that holds `path` ("." for a bare name).
std::string parent_directory(const std::string& path) {
  const fs::path target(path);
  return target.has_parent_path() ? target.parent_path().string() : std::string(".");
}

/// The temporary-name pattern for `path`: hidden, in the same directory.
std::string temp_pattern(const std::string& path, const std::string& suffix) {
  const fs::path target(path);
  return (fs::path(parent_directory(path)) / ("." + target.filename().string() + ".tmp-XXXXXX" + suffix)).string();
}

void sync_descriptor(int fd, const std::string& path, const char* step) {
  if (::fsync(fd) != 0) {
    const int error = errno;
    ::close(fd);
    throw failure(path, step, error);
  }
  ::close(fd);
}

void sync_directory_of(const std::string& path) { sync_path(parent_directory(path)); }

/// Renames `temp` over `path` and flushes the directory entry.
void publish(const std::string& temp, const std::string& path) {
  if (::rename(temp.c_str(), path.c_str()) != 0)
    throw failure(path, "cannot rename the temporary output into place", errno);
  sync_directory_of(path);
}

/// Writes all of [data, data + size) to fd; false (errno set) on failure.
bool write_all(int fd, const char* data, std::size_t size) {
  std::size_t written = 0;
  while (written < size) {
    const ssize_t n = ::write(fd, data + written, size - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    written += static_cast<std::size_t>(n);
  }
  return true;
}

constexpr std::size_t kStreamBuffer = 1 << 16;

}  // namespace

void sync_path(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw failure(path, "cannot open it to flush it", errno);
  sync_descriptor(fd, path, "cannot flush it to disk");
}

void write_file_atomically(const std::string& path, const void* bytes, std::size_t size) {
  std::string temp = temp_pattern(path, "");
  const int fd = ::mkstemp(temp.data());
  if (fd < 0) throw failure(path, "cannot create a temporary file next to it", errno);
  auto abandon = [&](const char* step) {
    const int error = errno;
    ::close(fd);
    ::unlink(temp.c_str());
    return failure(path, step, error);
  };
  if (!write_all(fd, static_cast<const char*>(bytes), size)) throw abandon("write failed");
  // mkstemp creates 0600; outputs are ordinary readable files.
  if (::fchmod(fd, 0644) != 0 || ::fsync(fd) != 0) throw abandon("flush failed");
  ::close(fd);
  try {
    publish(temp, path);
  } catch (...) {
    ::unlink(temp.c_str());
    throw;
  }
}

void write_file_atomically(const std::string& path, const std::string& text) {
  write_file_atomically(path, text.data(), text.size());
}

AtomicFile::AtomicFile(const std::string& path, const std::string& extension) : path_(path) {
  std::string pattern = temp_pattern(path, extension);
  const int fd = ::mkstemps(pattern.data(), static_cast<int>(extension.size()));
  if (fd < 0) throw failure(path, "cannot create a temporary file next to it", errno);
  ::fchmod(fd, 0644);
  ::close(fd);
  temp_ = pattern;
}

AtomicFile::~AtomicFile() {
  if (!temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicFile::commit() {
  sync_path(temp_);
  publish(temp_, path_);
  temp_.clear();
}

AtomicStream::AtomicStream(const std::string& path) : path_(path), buffer_(kStreamBuffer, '\0') {
  std::string temp = temp_pattern(path, "");
  fd_ = ::mkstemp(temp.data());
  if (fd_ < 0) throw failure(path, "cannot create a temporary file next to it", errno);
  ::fchmod(fd_, 0644);
  temp_ = temp;
}

AtomicStream::~AtomicStream() {
  if (fd_ >= 0) ::close(fd_);
  if (!temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicStream::flush_buffer() {
  if (temp_.empty()) throw std::runtime_error("cannot write '" + path_ + "': it was already published");
  if (!write_all(fd_, buffer_.data(), buffered_)) throw failure(path_, "write failed", errno);
  written_ += buffered_;
  buffered_ = 0;
}

void AtomicStream::append(const char* bytes, std::size_t size) {
  if (buffered_ + size > buffer_.size()) {
    flush_buffer();
    if (size > buffer_.size()) {
      if (!write_all(fd_, bytes, size)) throw failure(path_, "write failed", errno);
      written_ += size;
      return;
    }
  }
  std::memcpy(buffer_.data() + buffered_, bytes, size);
  buffered_ += size;
}

void AtomicStream::commit() {
  flush_buffer();
  if (::fsync(fd_) != 0) throw failure(path_, "flush failed", errno);
  ::close(fd_);
  fd_ = -1;
  publish(temp_, path_);
  temp_.clear();
}

AtomicDirectory::AtomicDirectory(const std::string& path) : path_(path) {
  std::error_code error;
  if (fs::exists(path, error) && !(fs::is_directory(path, error) && fs::is_empty(path, error)))
    throw std::runtime_error("cannot write '" + path +
                             "': it exists and is not an empty directory; choose a new directory");
  std::string pattern = temp_pattern(path, "");
  if (::mkdtemp(pattern.data()) == nullptr)
    throw failure(path, "cannot create a temporary directory next to it", errno);
  ::chmod(pattern.c_str(), 0755);
  temp_ = pattern;
}

AtomicDirectory::~AtomicDirectory() {
  if (temp_.empty()) return;
  std::error_code ignored;
  fs::remove_all(temp_, ignored);
}

void AtomicDirectory::commit() {
  std::error_code error;
  for (const auto& entry : fs::recursive_directory_iterator(temp_, error))
    if (entry.is_regular_file()) sync_path(entry.path().string());
  if (error) throw failure(path_, "cannot list the temporary directory", error.value());
  sync_path(temp_);
  // rename() replaces an empty directory; a directory that gained files since
  // the constructor checked makes it fail with ENOTEMPTY, which is reported.
  publish(temp_, path_);
  temp_.clear();
}

}  // namespace organsim::io
