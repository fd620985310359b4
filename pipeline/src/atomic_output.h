// Atomic output for writers that insist on a file name (ITK, VTK): they write
// a temporary file in the target directory, which then replaces the target.
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>

#include <sys/stat.h>
#include <unistd.h>

namespace organsim::pipeline {

/// A unique temporary file next to `path`, ending in `extension` (ITK and VTK
/// pick the file format by extension), renamed over `path` by commit() and
/// removed if never committed.
class AtomicOutput {
 public:
  AtomicOutput(const std::string& path, const std::string& extension) : path_(path) {
    const std::filesystem::path target(path);
    const std::filesystem::path directory = target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
    std::string pattern = (directory / ("." + target.filename().string() + ".tmp-XXXXXX" + extension)).string();
    const int fd = ::mkstemps(pattern.data(), static_cast<int>(extension.size()));
    if (fd < 0)
      throw std::runtime_error("cannot write '" + path + "': " + std::strerror(errno) +
                               "; check that the directory exists and is writable");
    ::fchmod(fd, 0644);  // mkstemps creates 0600; outputs are ordinary readable files
    ::close(fd);
    temp_ = pattern;
  }
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;
  ~AtomicOutput() {
    if (!temp_.empty()) ::unlink(temp_.c_str());
  }
  const std::string& temp_path() const { return temp_; }
  void commit() {
    if (std::rename(temp_.c_str(), path_.c_str()) != 0)
      throw std::runtime_error("cannot write '" + path_ + "': " + std::strerror(errno));
    temp_.clear();
  }

 private:
  std::string path_;
  std::string temp_;
};

}  // namespace organsim::pipeline
