// meniscus tests — all-or-nothing file output: no partial targets, no stray temporary files.
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/resource.h>

#include "io/atomic_file.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using io::AtomicFile;
using test::TempDir;

std::vector<std::string> directory_listing(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(AtomicWrite, CommitLeavesOnlyTheTarget) {
  TempDir dir;
  const std::string target = dir.file("out.bin");
  {
    AtomicFile file(target);
    EXPECT_EQ(std::filesystem::path(file.temp_path()).parent_path(), dir.path);
    EXPECT_TRUE(std::filesystem::path(file.temp_path()).filename().string().starts_with(".out.bin.meniscus-tmp-"));
    file.write(std::string_view("hello "));
    file.write(std::string_view("world"));
    EXPECT_FALSE(std::filesystem::exists(target));  // nothing visible before commit
    file.commit();
  }
  EXPECT_EQ(read_file(target), "hello world");
  EXPECT_EQ(directory_listing(dir.path), std::vector<std::string>{"out.bin"});
}

TEST(AtomicWrite, LargeWritesArriveIntact) {
  TempDir dir;
  const std::string target = dir.file("big.bin");
  std::string expected;
  {
    AtomicFile file(target);
    for (int i = 0; i < 5; ++i) {
      const std::string block(std::size_t(700000 + i * 300000), char('a' + i));  // crosses the 1 MiB buffer
      file.write(block);
      expected += block;
    }
    file.commit();
  }
  EXPECT_EQ(read_file(target), expected);
  EXPECT_EQ(directory_listing(dir.path), std::vector<std::string>{"big.bin"});
}

TEST(AtomicWrite, ExceptionBeforeCommitKeepsThePreviousTarget) {
  TempDir dir;
  const std::string target = dir.file("keep.txt");
  { std::ofstream(target) << "old"; }
  try {
    AtomicFile file(target);
    file.write(std::string(3 << 20, 'x'));  // some of it reaches the disk
    throw std::runtime_error("writer failed midway");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(read_file(target), "old");
  EXPECT_EQ(directory_listing(dir.path), std::vector<std::string>{"keep.txt"});
}

TEST(AtomicWrite, UncommittedNewTargetDoesNotExist) {
  TempDir dir;
  const std::string target = dir.file("never.txt");
  { AtomicFile file(target); file.write(std::string_view("partial")); }
  EXPECT_FALSE(std::filesystem::exists(target));
  EXPECT_TRUE(std::filesystem::is_empty(dir.path));
}

TEST(AtomicWrite, MissingDirectoryIsAnIoErrorNamingTheTarget) {
  TempDir dir;
  const std::string target = dir.file("no/such/dir/out.ply");
  try {
    AtomicFile file(target);
    FAIL() << "expected IoError";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(target), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("No such file or directory"), std::string::npos) << e.what();
  }
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}};
  EXPECT_THROW(write_mesh(target, mesh), IoError);
  EXPECT_FALSE(std::filesystem::exists(target));
  EXPECT_TRUE(std::filesystem::is_empty(dir.path));
}

TEST(AtomicWrite, FailedRenameRemovesTheTemporaryFile) {
  TempDir dir;
  const std::string target = dir.file("occupied");
  std::filesystem::create_directories(std::filesystem::path(target) / "child");  // a non-empty directory
  try {
    AtomicFile file(target);
    file.write(std::string_view("data"));
    file.commit();
    FAIL() << "expected IoError";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(target), std::string::npos) << e.what();
  }
  EXPECT_TRUE(std::filesystem::is_directory(target));
  EXPECT_EQ(directory_listing(dir.path), std::vector<std::string>{"occupied"});
}

// The file-size limit makes write(2) fail with EFBIG partway through, the way a full disk fails
// with ENOSPC, without needing a full file system.
TEST(AtomicWrite, WriteFailureMidwayLeavesNoTargetAndNoTemporaryFile) {
  TempDir dir;
  const std::string target = dir.file("mesh.ply");
  TriangleMesh mesh;
  mesh.vertices = test::lattice_block(60, 60, 60, 0.1f).positions;  // 2.6 MB of positions
  for (uint32_t i = 0; i + 2 < mesh.vertices.size(); i += 3) mesh.triangles.push_back({i, i + 1, i + 2});

  struct rlimit saved {};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  auto* previous = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit small = saved;
  small.rlim_cur = 1 << 20;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string message;
  try {
    write_mesh(target, mesh);
  } catch (const IoError& e) {
    message = e.what();
  }
  setrlimit(RLIMIT_FSIZE, &saved);
  std::signal(SIGXFSZ, previous);

  EXPECT_NE(message.find(target), std::string::npos) << "message: " << message;
  EXPECT_NE(message.find("File too large"), std::string::npos) << "message: " << message;
  EXPECT_FALSE(std::filesystem::exists(target));
  EXPECT_TRUE(std::filesystem::is_empty(dir.path));

  write_mesh(target, mesh);  // and with the limit lifted it succeeds
  EXPECT_EQ(read_mesh(target).vertices.size(), mesh.vertices.size());
  EXPECT_EQ(directory_listing(dir.path), std::vector<std::string>{"mesh.ply"});
}

}  // namespace
}  // namespace meniscus
