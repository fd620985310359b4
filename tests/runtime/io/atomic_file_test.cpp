// Atomic output: a file or directory appears complete or not at all, and an
// existing target survives a failed write.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include <csignal>

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "organsim/io/atomic_file.h"
#include "temp_directory.h"

namespace organsim::io {
namespace {

namespace fs = std::filesystem;

class AtomicOutput : public organsim::testing::TempDirectoryTest {
 protected:
  static std::string read(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }
};

TEST_F(AtomicOutput, BytesReplaceTheTargetAndLeaveNoTemporaryFile) {
  const fs::path target = dir_ / "forces.csv";
  write_file_atomically(target.string(), "first");
  write_file_atomically(target.string(), std::string("second\0x", 8));
  EXPECT_EQ(read(target), std::string("second\0x", 8));
  EXPECT_EQ(entries(), 1);
  EXPECT_EQ(fs::status(target).permissions() & fs::perms::others_read, fs::perms::others_read);
}

TEST_F(AtomicOutput, AMissingDirectoryIsAOneLineErrorNamingThePath) {
  const std::string target = (dir_ / "missing" / "model.organ").string();
  try {
    write_file_atomically(target, "x");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(target), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

TEST_F(AtomicOutput, AnUncommittedFileLeavesNothingAndKeepsTheOldTarget) {
  const fs::path target = dir_ / "surface.vtp";
  write_file_atomically(target.string(), "old");
  {
    AtomicFile output(target.string(), ".vtp");
    EXPECT_EQ(fs::path(output.temp_path()).parent_path(), dir_);
    EXPECT_EQ(fs::path(output.temp_path()).extension(), ".vtp");  // writers pick the format by extension
    std::ofstream(output.temp_path()) << "new but abandoned";
  }
  EXPECT_EQ(read(target), "old");
  EXPECT_EQ(entries(), 1);
}

TEST_F(AtomicOutput, ACommittedFileReplacesTheTarget) {
  const fs::path target = dir_ / "mask.nii.gz";
  AtomicFile output(target.string(), ".nii.gz");
  std::ofstream(output.temp_path()) << "voxels";
  output.commit();
  EXPECT_EQ(read(target), "voxels");
  EXPECT_EQ(entries(), 1);
}

TEST_F(AtomicOutput, AStreamAppearsWholeAtCommitAndNotBefore) {
  const fs::path target = dir_ / "forces.csv";
  write_file_atomically(target.string(), "old");
  {
    AtomicStream stream(target.string());
    std::string expected;
    for (int i = 0; i < 20000; ++i) {  // several buffers' worth
      const std::string line = std::to_string(i) + ",0.125,-3.5\n";
      stream.append(line);
      expected += line;
    }
    stream.append(std::string(100000, 'x'));  // larger than the buffer
    expected += std::string(100000, 'x');
    EXPECT_EQ(read(target), "old");  // unchanged until commit
    EXPECT_EQ(stream.size(), expected.size());
    stream.commit();
    EXPECT_EQ(read(target), expected);
  }
  EXPECT_EQ(entries(), 1);
  {
    AtomicStream abandoned(target.string());
    abandoned.append("partial");
  }
  EXPECT_EQ(entries(), 1);  // the temporary file is gone, the target kept
  EXPECT_NE(read(target), "partial");
}

// The disk fills (here: the process's file-size limit, RLIMIT_FSIZE, in a
// child process): the append that fails throws one line naming the path, and
// nothing is left behind.
TEST_F(AtomicOutput, AFullDiskIsAOneLineErrorAndLeavesNoFile) {
  const fs::path target = dir_ / "forces.csv";
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{200000, 200000};
    setrlimit(RLIMIT_FSIZE, &limit);
    try {
      AtomicStream stream(target.string());
      for (int i = 0; i < 100000; ++i) stream.append("0.001000,1,0.5,0.25,-0.125,1\n");
      stream.commit();
      _exit(2);  // the limit did not stop it
    } catch (const std::runtime_error& e) {
      const std::string message = e.what();
      const bool named = message.find(target.string()) != std::string::npos &&
                         message.find("File too large") != std::string::npos && message.find('\n') == std::string::npos;
      _exit(named ? 0 : 3);
    }
  }
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << status;
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_EQ(entries(), 0);
}

TEST_F(AtomicOutput, ADirectoryAppearsWholeOrNotAtAll) {
  const fs::path target = dir_ / "series";
  {
    AtomicDirectory abandoned(target.string());
    std::ofstream(fs::path(abandoned.temp_path()) / "slice0001.dcm") << "a";
  }
  EXPECT_FALSE(fs::exists(target));
  EXPECT_EQ(entries(), 0);
  AtomicDirectory output(target.string());
  std::ofstream(fs::path(output.temp_path()) / "slice0001.dcm") << "a";
  std::ofstream(fs::path(output.temp_path()) / "slice0002.dcm") << "b";
  output.commit();
  EXPECT_EQ(read(target / "slice0002.dcm"), "b");
  EXPECT_EQ(entries(), 1);
}

TEST_F(AtomicOutput, ADirectoryReplacesOnlyAnEmptyOne) {
  const fs::path target = dir_ / "series";
  fs::create_directories(target);
  AtomicDirectory output(target.string());  // an empty directory may be replaced
  std::ofstream(fs::path(output.temp_path()) / "slice.dcm") << "a";
  output.commit();
  EXPECT_TRUE(fs::exists(target / "slice.dcm"));
  EXPECT_THROW(AtomicDirectory again(target.string()), std::runtime_error);  // not empty any more
}

}  // namespace
}  // namespace organsim::io
