// meniscus tests — all-or-nothing file output: no partial targets, no stray temporary files.
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>
#include <functional>
#include <random>
#include <thread>

#include "io/vdb_export.hpp"
#include "io/atomic_file.hpp"
#include "io/file_bytes.hpp"
#include "io/vtu.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "meniscus/render.hpp"
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

TEST(AtomicWrite, FollowsSymlinksToTheirTargetAndKeepsThem) {
  TempDir dir;
  std::filesystem::create_directory(dir.path / "real");
  std::filesystem::create_symlink("real/target.txt", dir.path / "dangling.txt");  // no target yet
  std::filesystem::create_symlink("dangling.txt", dir.path / "chain.txt");
  {
    AtomicFile file(dir.file("chain.txt"));
    EXPECT_EQ(std::filesystem::path(file.destination()), dir.path / "real/target.txt");
    EXPECT_EQ(std::filesystem::path(file.temp_path()).parent_path(), dir.path / "real");
    file.write(std::string_view("through two links"));
    file.commit();
  }
  EXPECT_TRUE(std::filesystem::is_symlink(dir.path / "chain.txt"));
  EXPECT_TRUE(std::filesystem::is_symlink(dir.path / "dangling.txt"));
  EXPECT_EQ(read_file(dir.file("real/target.txt")), "through two links");
  EXPECT_EQ(directory_listing(dir.path / "real"), std::vector<std::string>{"target.txt"});
  // A loop of links is an error naming the file, not a hang.
  std::filesystem::create_symlink("b", dir.path / "a");
  std::filesystem::create_symlink("a", dir.path / "b");
  EXPECT_THROW(AtomicFile(dir.file("a")), IoError);
}

TEST(AtomicWrite, DevicesAreWrittenInPlaceAndFoldersRefused) {
  {
    AtomicFile file("/dev/null");
    EXPECT_TRUE(file.temp_path().empty());  // nothing to rename: /dev is left alone
    file.write(std::string(3 << 20, 'x'));
    file.commit();
  }
  EXPECT_TRUE(std::filesystem::is_character_file("/dev/null"));
  TempDir dir;
  try {
    AtomicFile file(dir.path.string());
    ADD_FAILURE() << "wrote over a folder";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("it is a folder"), std::string::npos) << e.what();
  }
}

TEST(AtomicWrite, AReplacedFileKeepsItsPermissions) {
  TempDir dir;
  const std::string target = dir.file("script.sh");
  { std::ofstream(target) << "old"; }
  std::filesystem::permissions(target, std::filesystem::perms(0750));
  AtomicFile file(target);
  file.write(std::string_view("new"));
  file.commit();
  EXPECT_EQ(read_file(target), "new");
  EXPECT_EQ(std::filesystem::status(target).permissions(), std::filesystem::perms(0750));
}

TEST(AtomicWrite, TemporariesOfProcessesThatAreGoneAreRemoved) {
  TempDir dir;
  // A temporary of this machine left by a process that no longer runs (a child that exited), one
  // of a live process (this one's parent), one of another machine and a user's own hidden file.
  std::string mine;
  {
    TempDir elsewhere;  // each folder is tidied once a process: the probe writes in another
    AtomicFile probe(elsewhere.file("x"));
    mine = std::filesystem::path(probe.temp_path()).filename().string();
  }
  ASSERT_TRUE(io::is_temporary_name(mine));
  const std::string marker = ".meniscus-tmp-";
  const std::string host_and_pid = mine.substr(mine.find(marker) + marker.size());
  const std::string host = host_and_pid.substr(0, host_and_pid.rfind('-', host_and_pid.rfind('-') - 1));
  const pid_t gone = fork();
  if (gone == 0) _exit(0);
  waitpid(gone, nullptr, 0);
  const auto name = [&](const std::string& h, long pid) {
    return fmt::format(".mesh.ply{}{}-{}-0123456789abcdef", marker, h, pid);
  };
  const std::string stale = name(host, gone), live = name(host, getppid()), remote = name("elsewhere", gone);
  for (const std::string& f : {stale, live, remote, std::string(".mine.tmp"), std::string("mesh.ply")})
    std::ofstream(dir.path / f) << "x";
  AtomicFile file(dir.file("other.ply"));
  file.write(std::string_view("data"));
  file.commit();
  const std::vector<std::string> left = directory_listing(dir.path);
  EXPECT_EQ(std::count(left.begin(), left.end(), stale), 0) << "the stale temporary stayed";
  for (const std::string& kept : {live, remote, std::string(".mine.tmp"), std::string("mesh.ply")})
    EXPECT_EQ(std::count(left.begin(), left.end(), kept), 1) << kept << " was removed";
  EXPECT_FALSE(io::is_temporary_name("mesh.ply"));
  EXPECT_FALSE(io::is_temporary_name(".mesh.ply.meniscus-tmp-host-12-xyz"));
}

TEST(AtomicWrite, GzipIsStreamedIntoTheTemporaryWithoutAnyOtherFile) {
  TempDir dir;
  const std::string target = dir.file("data.txt.gz");
  std::string plain;
  for (int64_t i = 0; i < 200000; ++i) plain += fmt::format("{} {}\n", i, i * i);
  {
    AtomicFile file(target);
    file.write(plain.substr(0, plain.size() / 2));
    // Half written: the hidden temporary is the only file, and it holds compressed bytes.
    const std::vector<std::string> during = directory_listing(dir.path);
    ASSERT_EQ(during.size(), 1u);
    EXPECT_TRUE(io::is_temporary_name(during[0])) << during[0];
    file.write(plain.substr(plain.size() / 2));
    file.commit();
  }
  EXPECT_EQ(directory_listing(dir.path), std::vector<std::string>{"data.txt.gz"});
  const std::string packed = read_file(target);
  EXPECT_LT(packed.size(), plain.size() / 2);
  EXPECT_EQ(uint8_t(packed[0]), 0x1f);
  const io::ByteBuffer inflated = io::read_file_content(target);
  EXPECT_EQ(std::string(inflated.begin(), inflated.end()), plain);
}

TEST(AtomicWrite, TwoWritersOfOneTargetBothFinishAndOneWholeFileIsLeft) {
  TempDir dir;
  const std::string target = dir.file("shared.ply.gz");
  const std::string a(4 << 20, 'a'), b(4 << 20, 'b');
  std::vector<std::string> errors(2);
  std::thread first([&] {
    try {
      AtomicFile f(target);
      f.write(a);
      f.commit();
    } catch (const std::exception& e) {
      errors[0] = e.what();
    }
  });
  std::thread second([&] {
    try {
      AtomicFile f(target);
      f.write(b);
      f.commit();
    } catch (const std::exception& e) {
      errors[1] = e.what();
    }
  });
  first.join();
  second.join();
  EXPECT_EQ(errors, std::vector<std::string>(2));
  const io::ByteBuffer content = io::read_file_content(target);
  const std::string got(content.begin(), content.end());
  EXPECT_TRUE(got == a || got == b) << "a mix of the two writes";
  EXPECT_EQ(directory_listing(dir.path), std::vector<std::string>{"shared.ply.gz"});
}

// Every output kind fails cleanly on a full disk (the file-size limit fails write(2) the way a
// full disk does): an IoError naming the file, nothing left in its folder.
TEST(AtomicWrite, EveryWriterFailsCleanlyWhenTheDiskFills) {
  TriangleMesh mesh;
  mesh.vertices = test::lattice_block(30, 30, 30, 0.1f).positions;
  for (uint32_t i = 0; i + 2 < mesh.vertices.size(); i += 3) mesh.triangles.push_back({i, i + 1, i + 2});
  mesh.normals.assign(mesh.vertices.size(), Vec3f{0, 0, 1});
  const ParticleSet particles = test::lattice_block(12, 12, 12, 0.1f);
  Params field_params = resolve_params(particles, Params{});
  Image picture;
  picture.width = picture.height = 256;
  picture.rgb.resize(256 * 256 * 3);
  std::mt19937 noise(7);  // incompressible: the PNG is larger than the limit
  for (uint8_t& byte : picture.rgb) byte = uint8_t(noise());
  std::vector<std::pair<std::string, std::function<void(const std::string&)>>> writers;
  for (const char* ext : {"ply", "ply.gz", "bgeo", "bgeo.gz", "bgeo.sc", "obj", "vtk", "vtp", "usda"})
    writers.push_back({std::string("mesh.") + ext, [&](const std::string& p) { write_mesh(p, mesh); }});
  writers.push_back({"index.pvtp", [&](const std::string& p) {
                       std::vector<std::string> pieces(3000, std::string(100, 'p'));
                       io::write_pvtp_index(p, pieces, mesh);
                     }});
  writers.push_back({"picture.png", [&](const std::string& p) { write_png(p, picture); }});
  writers.push_back({"stats.json", [&](const std::string& p) {
                       io::AtomicFile f(p);
                       f.write(std::string(100000, ' '));
                       f.commit();
                     }});
  if (has_openvdb()) writers.push_back({"field.vdb", [&](const std::string& p) { write_field_vdb(p, particles, field_params); }});

  struct rlimit saved {};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  auto* previous = std::signal(SIGXFSZ, SIG_IGN);
  for (const auto& [name, write] : writers) {
    TempDir dir;
    const std::string target = dir.file(name);
    struct rlimit small = saved;
    small.rlim_cur = 4096;
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
    std::string message;
    try {
      write(target);
    } catch (const IoError& e) {
      message = e.what();
    }
    setrlimit(RLIMIT_FSIZE, &saved);
    EXPECT_NE(message.find(target), std::string::npos) << name << ": " << message;
    EXPECT_NE(message.find("File too large"), std::string::npos) << name << ": " << message;
    EXPECT_TRUE(std::filesystem::is_empty(dir.path)) << name << " left a file";
    write(target);  // with room it is written whole
    EXPECT_EQ(directory_listing(dir.path), std::vector<std::string>{name});
  }
  std::signal(SIGXFSZ, previous);
}

}  // namespace
}  // namespace meniscus
