// End-to-end tests of what meniscus promises about a user's files and machine (docs/cli.md
// "Safety"): it never overwrites an input nor lets two outputs share a file, writes through
// symlinks, leaves no partial file on a full disk or when killed, holds --max-memory whatever the
// input, refuses absurd options at once, escapes bytes quoted from files and exits with the
// documented codes.
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <sys/wait.h>
#include <set>
#include <thread>
#include <unistd.h>
#include <zlib.h>

#include "io/atomic_file.hpp"
#include "meniscus/io.hpp"
#include "support/png_decode.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

/// What a refused run may use beyond --max-memory: the process itself (the program, its
/// libraries, the thread pool), about 40 MB here, and the reader's 1 MB chunk and zlib's state.
constexpr double kFixedOverhead = 64e6;

std::string q(const std::string& s) { return "'" + s + "'"; }
std::string meniscus(const std::string& args) { return "exec " + test::cli() + " " + args; }
std::string small_frame() { return test::data_file("ply/dam_break_frame_9_6859_particles.ply"); }

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void spit(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

std::vector<std::string> listing(const fs::path& dir, bool hidden) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (hidden || name[0] != '.') names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

/// A gzip file of `megabytes` MB of `fill` behind `header`, compressed as it is written (the
/// inflated stream is never held), as one member or several concatenated.
void write_gzip_bomb(const fs::path& path, const std::string& header, char fill, int megabytes, int members = 1) {
  std::ofstream out(path, std::ios::binary);
  const std::string block(1 << 20, fill);
  std::vector<char> buffer(1 << 20);
  for (int m = 0; m < members; ++m) {
    z_stream z{};
    ASSERT_EQ(deflateInit2(&z, Z_BEST_COMPRESSION, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY), Z_OK);
    const auto feed = [&](const char* data, std::size_t n, int flush) {
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data));
      z.avail_in = uInt(n);
      do {
        z.next_out = reinterpret_cast<Bytef*>(buffer.data());
        z.avail_out = uInt(buffer.size());
        deflate(&z, flush);
        out.write(buffer.data(), std::streamsize(buffer.size() - z.avail_out));
      } while (z.avail_out == 0);
    };
    if (m == 0) feed(header.data(), header.size(), Z_NO_FLUSH);
    for (int i = 0; i < megabytes / members; ++i) feed(block.data(), block.size(), Z_NO_FLUSH);
    feed(nullptr, 0, Z_FINISH);
    deflateEnd(&z);
  }
}

// --- never destroy a file ---------------------------------------------------------------------

TEST(Safety, NeverOverwritesAnInput) {
  TempDir t;
  fs::copy_file(small_frame(), t.path / "p.ply");
  fs::create_symlink("p.ply", t.path / "link.ply");
  fs::create_hard_link(t.path / "p.ply", t.path / "hard.ply");
  spit(t.path / "c.json", "{\"steps_a\": 3}");
  for (const char* f : {"seq_0001.ply", "seq_0002.ply"}) fs::copy_file(small_frame(), t.path / f);
  const std::string frame = slurp(t.path / "p.ply");
  const std::vector<std::string> before = listing(t.path, true);
  const std::string d = t.path.string() + "/";
  const std::vector<std::string> cases = {
      "surface " + d + "p.ply -o " + d + "p.ply",
      "surface " + d + "link.ply -o " + d + "p.ply",
      "surface " + d + "p.ply -o " + d + "link.ply",
      "surface " + d + "p.ply -o " + d + "hard.ply",
      "surface " + d + "p.ply -o " + d + "sub/../p.ply",
      "surface " + d + "p.ply -o " + d + "m.ply --config " + d + "c.json --stats " + d + "c.json",
      "surface " + q(d + "seq_####.ply") + " -o " + q(d + "seq_####.ply"),
      "surface " + q(d + "seq_####.ply") + " -o " + q(d + "out_####.ply") + " --stats " + q(d + "seq_####.ply"),
      "merge " + d + "p.ply -o " + d + "p.ply",
      "render " + d + "p.ply -o " + d + "x.png --particles " + d + "x.png",
  };
  spit(t.path / "x.png", "a picture, or a particle file: either way an input");
  for (const std::string& args : cases) {
    const test::Measured r = test::run_measured(meniscus(args));
    EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find("is the same file as"), std::string::npos) << args << "\n" << r.output;
    EXPECT_EQ(slurp(t.path / "p.ply"), frame) << args;
    EXPECT_EQ(slurp(t.path / "seq_0001.ply"), frame) << args;
    EXPECT_EQ(slurp(t.path / "c.json"), "{\"steps_a\": 3}") << args;
  }
  std::vector<std::string> after = listing(t.path, true);
  std::erase(after, "x.png");
  EXPECT_EQ(after, before) << "a refused run made files";
}

TEST(Safety, TwoOutputsNeverShareAFile) {
  TempDir t;
  const std::string d = t.path.string() + "/";
  for (const std::string& outputs : {"-o " + d + "m.ply --stats " + d + "m.ply",
                                     "-o " + d + "m.ply --stats " + d + "s.json --save-field " + d + "s.json",
                                     "-o " + d + "m.ply --preview " + d + "p.png --stats " + d + "p.png"}) {
    const test::Measured r = test::run_measured(meniscus("surface " + small_frame() + " " + outputs));
    EXPECT_EQ(r.status, 2) << outputs << "\n" << r.output;
    EXPECT_NE(r.output.find("each output needs its own file"), std::string::npos) << r.output;
    EXPECT_TRUE(listing(t.path, true).empty()) << outputs;
  }
}

TEST(Safety, OutputsAreCheckedBeforeAnyWork) {
  TempDir t;
  fs::create_directory(t.path / "folder.ply");
  spit(t.path / "file", "x");
  const std::string d = t.path.string() + "/";
  for (const auto& [option, path, says] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"-o", d + "folder.ply", "is a folder"},
           {"-o", d + "file/m.ply", "is not a folder"},
           {"--stats", d + "folder.ply", "is a folder"},
           {"--preview", d + "file/p.png", "is not a folder"}}) {
    const std::string args = option == "-o" ? "-o " + path : "-o " + d + "m.ply " + option + " " + path;
    const test::Measured r = test::run_measured(meniscus("surface " + small_frame() + " " + args));
    EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("read 6859 particles"), std::string::npos) << "the work started: " << r.output;
    EXPECT_FALSE(fs::exists(t.path / "m.ply"));
  }
}

TEST(Safety, OutputsAreWrittenThroughSymlinksWhichStay) {
  TempDir t;
  fs::create_directory(t.path / "real");
  // A dangling link, a chain of two, and links to files that exist (replaced through the link).
  fs::create_symlink("real/mesh.ply", t.path / "m.ply");
  fs::create_symlink("real/stats.json", t.path / "s1.json");
  fs::create_symlink("s1.json", t.path / "s.json");
  spit(t.path / "real/view.png", "old picture");
  fs::create_symlink(t.path / "real/view.png", t.path / "p.png");
  fs::create_symlink("real/field.vdb", t.path / "f.vdb");
  const std::string d = t.path.string() + "/";
  const test::Measured r = test::run_measured(meniscus("surface " + small_frame() + " -q -o " + d + "m.ply --stats " + d +
                                                      "s.json --preview " + d + "p.png --save-field " + d + "f.vdb"));
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* link : {"m.ply", "s.json", "s1.json", "p.png", "f.vdb"})
    EXPECT_TRUE(fs::is_symlink(t.path / link)) << link << " was replaced by a file";
  EXPECT_EQ(read_mesh(d + "real/mesh.ply").vertices.size(), read_mesh(d + "m.ply").vertices.size());
  EXPECT_EQ(nlohmann::json::parse(slurp(t.path / "real/stats.json"))["particles"], 6859);
  EXPECT_GT(test::read_png(d + "real/view.png").width, 0);
  EXPECT_GT(fs::file_size(t.path / "real/field.vdb"), 1000u);
  EXPECT_EQ(listing(t.path, true), (std::vector<std::string>{"f.vdb", "m.ply", "p.png", "real", "s.json", "s1.json"}));
  EXPECT_EQ(listing(t.path / "real", true),
            (std::vector<std::string>{"field.vdb", "mesh.ply", "stats.json", "view.png"}));
}

TEST(Safety, OutputsThatCannotBeMadeAreRefusedBeforeTheWork) {
  TempDir t;
  const std::string d = t.path.string() + "/";
  fs::create_symlink("loop_b.ply", t.path / "loop_a.ply");
  fs::create_symlink("loop_a.ply", t.path / "loop_b.ply");
  struct Case {
    std::string args;
    int status;
    std::string says;
  };
  const std::vector<Case> cases = {
      // A name longer than a file name may be: found now, not at the rename after the work.
      {"surface " + small_frame() + " -o " + d + std::string(300, 'm') + ".ply", 2, "more than the 255 a file name may have"},
      {"surface " + small_frame() + " -o " + d + "m.ply --stats " + d + std::string(300, 's') + ".json", 2,
       "more than the 255"},
      // A loop of links: as an output a bad option, as the input bad input that is read, not written.
      {"surface " + small_frame() + " -o " + d + "loop_a.ply", 2, "-o '" + d + "loop_a.ply' cannot be written: its symbolic links make a loop"},
      {"surface " + d + "loop_a.ply -o " + d + "m.ply", 1, "cannot read the input '" + d + "loop_a.ply': its symbolic links make a loop"},
  };
  for (const Case& c : cases) {
    const test::Measured r = test::run_measured(meniscus(c.args + " -q"));
    EXPECT_EQ(r.status, c.status) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_LT(r.seconds, 2) << "refused before the work: " << c.args;
  }
  EXPECT_EQ(listing(t.path, true), (std::vector<std::string>{"loop_a.ply", "loop_b.ply"}));
}

TEST(Safety, AReadOnlyOutputIsNotReplacedForAUserWhoCannotWriteIt) {
  TempDir t;
  fs::permissions(t.path, fs::perms::all);  // the other user below works in it
  fs::copy_file(small_frame(), t.path / "in.ply");
  spit(t.path / "kept.ply", "mine");
  fs::permissions(t.path / "kept.ply", fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  // As root, as another user (cp refuses such a file to anyone but root).
  std::string as_user;
  if (::geteuid() == 0) {
    as_user = "setpriv --reuid=65534 --regid=65534 --clear-groups ";
    if (test::run_command(as_user + test::cli() + " --version >/dev/null 2>&1") != 0)
      GTEST_SKIP() << "SKIPPED: no other user can run " << test::cli() << " here (setpriv, or the folders' permissions)";
  }
  const test::Measured r = test::run_measured(as_user + test::cli() + " surface " + t.file("in.ply") + " -q -o " +
                                              t.file("kept.ply"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("is read-only for you: meniscus does not replace it"), std::string::npos) << r.output;
  EXPECT_EQ(slurp(t.path / "kept.ply"), "mine");
}

TEST(Safety, DevicesAndPipesAreWrittenInPlace) {
  const bool link_before = fs::is_symlink("/dev/stdout");
  const test::Measured r =
      test::run_measured(meniscus("surface " + small_frame() + " -q -o /tmp/.meniscus-null.ply --stats /dev/stdout"));
  fs::remove("/tmp/.meniscus-null.ply");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(r.output)["particles"], 6859) << r.output;
  EXPECT_EQ(fs::is_symlink("/dev/stdout"), link_before);
  EXPECT_TRUE(fs::exists("/dev/stdout"));

  // Through a real pipe, as `--stats /dev/stdout | jq .` has it: /dev/stdout and /proc/self/fd/1
  // then link to "pipe:[…]", which names no file; and a named pipe (FIFO) with its reader.
  TempDir t;
  for (const std::string stdout_name : {"/dev/stdout", "/proc/self/fd/1"}) {
    const test::Measured piped = test::run_measured("{ " + test::cli() + " surface " + small_frame() + " -q -o " +
                                                    q((t.path / "m.ply").string()) + " --stats " + stdout_name +
                                                    "; echo \"@@status $?\"; } | cat");
    const std::size_t at = piped.output.rfind("@@status ");
    ASSERT_NE(at, std::string::npos) << piped.output;
    EXPECT_EQ(piped.output.substr(at), "@@status 0\n") << stdout_name << "\n" << piped.output;
    EXPECT_EQ(nlohmann::json::parse(piped.output.substr(0, at))["particles"], 6859) << stdout_name;
  }
  const fs::path fifo = t.path / "stats.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const test::Measured through_fifo = test::run_measured(
      "cat " + q(fifo.string()) + " > " + q((t.path / "read.json").string()) + " & " + test::cli() + " surface " +
      small_frame() + " -q -o " + q((t.path / "m.ply").string()) + " --stats " + q(fifo.string()) + "; rc=$?; wait; exit $rc");
  ASSERT_EQ(through_fifo.status, 0) << through_fifo.output;
  EXPECT_EQ(nlohmann::json::parse(slurp(t.path / "read.json"))["particles"], 6859);
  EXPECT_EQ(fs::status(fifo).type(), fs::file_type::fifo) << "the named pipe was replaced";
}

// --- a full disk, and a process killed mid-write ------------------------------------------------

/// Runs `command` in a private mount namespace with a full tmpfs on `dir` (a filler file takes
/// all its space); returns the run with the tmpfs's listing after it, or nullopt where mount
/// namespaces are not available (not root, or no CAP_SYS_ADMIN).
std::optional<std::pair<test::Measured, std::string>> on_full_disk(const fs::path& dir, const std::string& command) {
  const std::string script = "mount -t tmpfs -o size=64k tmpfs " + q(dir.string()) + " || exit 99; cat /dev/zero > " +
                             q((dir / "filler").string()) + " 2>/dev/null; (" + command +
                             "); rc=$?; echo @@listing; ls -A " + q(dir.string()) + "; exit $rc";
  test::Measured r = test::run_measured("unshare -m sh -c " + q(script));
  const std::size_t at = r.output.find("@@listing\n");
  if (r.status == 99 || at == std::string::npos) return std::nullopt;
  std::string files = r.output.substr(at + 10);
  r.output.resize(at);
  return std::pair{r, files};
}

TEST(Safety, AFullDiskIsAnErrorForEveryOutputAndLeavesNoFile) {
  TempDir t;
  fs::create_directory(t.path / "full");
  const std::string d = t.path.string() + "/", full = d + "full/", frame = small_frame();
  ASSERT_EQ(test::run_command(test::cli() + " surface " + frame + " -q -o " + d + "piece.ply"), 0);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"mesh .ply", "surface " + frame + " -o " + full + "m.ply"},
      {"mesh .ply.gz", "surface " + frame + " -o " + full + "m.ply.gz"},
      {"mesh .bgeo.sc", "surface " + frame + " -o " + full + "m.bgeo.sc"},
      {"--stats", "surface " + frame + " -o " + d + "m.ply --stats " + full + "s.json"},
      {"--preview", "surface " + frame + " -o " + d + "m.ply --preview " + full + "p.png"},
      {"--save-field", "surface " + frame + " -o " + d + "m.ply --save-field " + full + "f.vdb"},
      {"render", "render " + d + "piece.ply -o " + full + "r.png"},
      {"merge", "merge " + d + "piece.ply -o " + full + "merged.ply"},
  };
  for (const auto& [kind, args] : cases) {
    const auto run = on_full_disk(t.path / "full", test::cli() + " " + args);
    if (!run) GTEST_SKIP() << "no mount namespace here (needs root): the writers' own full-disk tests still run";
    const auto& [r, files] = *run;
    EXPECT_EQ(r.status, 1) << kind << "\n" << r.output;
    EXPECT_NE(r.output.find(full), std::string::npos) << kind << ": the message names the file\n" << r.output;
    EXPECT_NE(r.output.find("No space left on device"), std::string::npos) << kind << "\n" << r.output;
    EXPECT_EQ(files, "filler\n") << kind << ": left behind on the full disk";
  }
}

TEST(Safety, KilledMidWriteLeavesNoVisiblePartialFileAndTheNextRunTidies) {
  if (test::kSanitized) GTEST_SKIP() << "a dozen runs of a large frame, killed: the Release run has it";
  TempDir t;
  const std::string frame = test::data_file("dam_break_frame_23_24389_particles.bgeo");
  const auto command = [&](const fs::path& dir) {
    const std::string d = dir.string() + "/";
    return test::cli() + " surface " + frame + " -q -o " + d + "m.ply.gz --stats " + d + "s.json --preview " + d +
           "p.png --save-field " + d + "f.vdb";
  };
  // The outputs of a whole run, and how long it takes.
  fs::create_directory(t.path / "reference");
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(test::run_command(command(t.path / "reference")), 0);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string mesh = slurp(t.path / "reference/m.ply.gz"), picture = slurp(t.path / "reference/p.png");
  const auto field_size = fs::file_size(t.path / "reference/f.vdb");

  // Killed at moments of two kinds, and whatever the moment, every visible file is whole:
  //  - while the n-th output is being written: the test watches the folder and kills the run as
  //    soon as the n-th temporary appears (n = 1…4), so the kill lands mid-write however loaded
  //    the machine is (a small file written faster than the watch can see is simply not caught);
  //  - at moments spread over the reference run's time, to land in the computation as well.
  constexpr int kWatched = 4, kTimed = 4;
  fs::create_directory(t.path / "killed");
  const std::string line = command(t.path / "killed");
  const auto temporaries = [&] {
    std::set<std::string> names;
    for (const std::string& name : listing(t.path / "killed", true))
      if (io::is_temporary_name(name)) names.insert(name);
    return names;
  };
  int mid_write = 0;  // kills that left a temporary: they came while a file was being written
  std::set<std::string> seen;
  for (int k = 0; k < kWatched + kTimed; ++k) {
    for (const std::string& name : listing(t.path / "killed", false)) fs::remove(t.path / "killed" / name);
    const std::set<std::string> stale = temporaries();  // hidden leftovers of earlier kills
    const pid_t pid = fork();
    if (pid == 0) {
      execl("/bin/sh", "sh", "-c", ("exec " + line + " 2>/dev/null").c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    int status = 0;
    bool exited = false;
    if (k < kWatched) {
      std::set<std::string> appeared;
      while (static_cast<int>(appeared.size()) <= k) {
        if (waitpid(pid, &status, WNOHANG) == pid) {
          exited = true;
          break;
        }
        for (const std::string& name : temporaries())
          if (!stale.count(name)) appeared.insert(name);
        if (static_cast<int>(appeared.size()) <= k) std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
    } else {
      std::this_thread::sleep_for(std::chrono::duration<double>(seconds * (0.2 + 0.8 * (k - kWatched) / kTimed)));
    }
    if (!exited) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
    }
    bool left_one = false;
    for (const std::string& name : temporaries())
      if (!stale.count(name) && seen.insert(name).second) left_one = true;
    mid_write += left_one ? 1 : 0;
    for (const std::string& name : listing(t.path / "killed", false)) {
      const fs::path file = t.path / "killed" / name;
      if (name == "m.ply.gz") EXPECT_EQ(slurp(file), mesh) << "kill " << k << ": a partial mesh";
      else if (name == "p.png") EXPECT_EQ(slurp(file), picture) << "kill " << k << ": a partial picture";
      else if (name == "f.vdb") EXPECT_EQ(fs::file_size(file), field_size) << "kill " << k << ": a partial field";
      else if (name == "s.json") EXPECT_TRUE(nlohmann::json::accept(slurp(file))) << "kill " << k << ": partial stats";
      else ADD_FAILURE() << "kill " << k << ": a stray visible file " << name;
    }
  }
  EXPECT_GE(mid_write, 2) << "fewer than two kills came during a write: the test did not test";
  RecordProperty("kills_during_a_write", mid_write);
  // What SIGKILL cannot clean (hidden temporaries) the next run in the folder removes.
  ASSERT_EQ(test::run_command(line), 0);
  for (const std::string& name : listing(t.path / "killed", true))
    EXPECT_FALSE(io::is_temporary_name(name)) << "a stale temporary stayed: " << name;
  EXPECT_EQ(listing(t.path / "killed", true), (std::vector<std::string>{"f.vdb", "m.ply.gz", "p.png", "s.json"}));
}

TEST(Safety, InterruptedRunsRemoveTheirTemporaries) {
  TempDir t;
  const std::string frame = test::data_file("dam_break_frame_23_24389_particles.bgeo");
  const std::string line = test::cli() + " surface " + frame + " -q -o " + t.file("m.ply.gz") + " --stats " +
                           t.file("s.json") + " --preview " + t.file("p.png");
  for (const int signal : {SIGINT, SIGTERM}) {
    for (const double delay : {0.2, 0.4, 0.6, 0.8}) {
      for (const std::string& name : listing(t.path, true)) fs::remove(t.path / name);
      const pid_t pid = fork();
      if (pid == 0) {
        execl("/bin/sh", "sh", "-c", ("exec " + line).c_str(), static_cast<char*>(nullptr));
        _exit(127);
      }
      std::this_thread::sleep_for(std::chrono::duration<double>(delay));
      kill(pid, signal);
      int status = 0;
      waitpid(pid, &status, 0);
      EXPECT_TRUE(WIFSIGNALED(status) ? WTERMSIG(status) == signal : WEXITSTATUS(status) == 0) << status;
      for (const std::string& name : listing(t.path, true))
        EXPECT_FALSE(io::is_temporary_name(name)) << "signal " << signal << " after " << delay << " s left " << name;
    }
  }
}

// --- memory ---------------------------------------------------------------------------------------

/// A run refused for memory: exit 1 naming `says`, and (outside the sanitizers, whose shadow
/// memory is not the program's) a peak within --max-memory plus the fixed overhead.
void expect_refused_within(const std::string& args, double max_memory_gb, const std::string& says) {
  const test::Measured r = test::run_measured(meniscus(args + " --max-memory " + std::to_string(max_memory_gb)));
  EXPECT_EQ(r.status, 1) << args << "\n" << r.output;
  EXPECT_NE(r.output.find(says), std::string::npos) << args << "\n" << r.output;
  EXPECT_EQ(r.output.find("bad_alloc"), std::string::npos) << r.output;
  if (!test::kSanitized) {
    EXPECT_LE(r.peak_bytes, max_memory_gb * 1e9 + kFixedOverhead)
        << args << ": peak " << r.peak_bytes / 1e6 << " MB for --max-memory " << max_memory_gb;
  }
  EXPECT_LT(r.seconds, 30) << args;
}

// --decimate's points count in the frame's estimate: the dam break 23 peaks under 80 MB without
// --decimate and above it with, so within 80 MB it surfaces, and with --decimate it is refused
// before its field.
TEST(Safety, DecimationCountsInTheMemoryEstimate) {
  TempDir t;
  const std::string frame = test::data_file("ply/dam_break_frame_23_24389_particles.ply"),
                    out = " -q -o " + t.file("m.ply");
  if (!test::kSanitized) {
    const test::Measured ok = test::run_measured(meniscus("surface " + frame + out + " --max-memory 0.08"));
    EXPECT_EQ(ok.status, 0) << ok.output;
  }
  expect_refused_within("surface " + frame + out + " --decimate 0.02", 0.08, "smoothing and --decimate");
}

TEST(Safety, GzipBombsAndEndlessFilesAreRefusedWithinTheMemoryLimit) {
  TempDir t;
  const std::string d = t.path.string() + "/";
  write_gzip_bomb(t.path / "zeros.txt.gz", "", '\0', 400);
  write_gzip_bomb(t.path / "zeros.ply.gz", "ply\nformat ascii 1.0\nelement vertex 100000000\nproperty float x\n"
                                          "property float y\nproperty float z\nend_header\n", ' ', 400);
  write_gzip_bomb(t.path / "members.csv.gz", "x,y,z\n", '\n', 400, 8);
  expect_refused_within("surface " + d + "zeros.txt.gz -o " + d + "m.ply", 0.15, "inflates past 150 MB");
  expect_refused_within("surface " + d + "zeros.ply.gz -o " + d + "m.ply", 0.15, "inflates past 150 MB");
  expect_refused_within("surface " + d + "members.csv.gz -o " + d + "m.ply", 0.15, "inflates past 150 MB");
  expect_refused_within("surface /dev/zero -o " + d + "m.ply", 0.1, "'/dev/zero' goes on past 100 MB");
  // A bound that rounds to less than a byte is held at one byte, never read as "no bound".
  for (const char* tiny : {"1e-12", "1e-300"}) {
    for (const std::string& input : {d + "zeros.txt.gz", std::string("/dev/zero")}) {
      const test::Measured r = test::run_measured(meniscus("surface " + input + " -o " + d + "m.ply --max-memory " + tiny));
      EXPECT_EQ(r.status, 1) << tiny << " " << input << "\n" << r.output;
      EXPECT_NE(r.output.find("past 1 byte"), std::string::npos) << tiny << " " << input << "\n" << r.output;
      if (!test::kSanitized) {
        EXPECT_LE(r.peak_bytes, kFixedOverhead) << tiny << " " << input;
      }
      EXPECT_LT(r.seconds, 10) << tiny << " " << input;
    }
  }
  EXPECT_TRUE(listing(t.path, false) == (std::vector<std::string>{"members.csv.gz", "zeros.ply.gz", "zeros.txt.gz"}));
}

// Text that is not text, within the limit: a first line of 200 MB of NUL bytes, and a header of
// 200 MB of commas (200 million empty column names). Each is refused where it stops being text
// (the first NUL; the line's 16 MB bound), holding the inflated file and little more, quickly, in
// a message of a few hundred bytes.
TEST(Safety, HostileTextIsRefusedAtItsFirstBadByteWithinTheMemoryLimit) {
  TempDir t;
  const std::string d = t.path.string() + "/";
  write_gzip_bomb(t.path / "nul_line.txt.gz", "", '\0', 200);
  write_gzip_bomb(t.path / "commas.csv.gz", "", ',', 200);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"nul_line.txt.gz", "line 1, byte 0 (of the decompressed data): expected text, found the control byte 0x00"},
      {"commas.csv.gz", "line 1, byte 0 (of the decompressed data): expected a line of at most 16.0 MB"},
  };
  for (const auto& [name, says] : cases) {
    const std::string args = "surface " + d + name + " -o " + d + "m.ply";
    expect_refused_within(args, 0.3, says);
    const test::Measured r = test::run_measured(meniscus(args + " --max-memory 0.3"));
    EXPECT_LT(r.output.size(), 600u) << name << ": a message of " << r.output.size() << " bytes";
    EXPECT_LT(r.seconds, 10) << name;
  }
  EXPECT_EQ(listing(t.path, false), (std::vector<std::string>{"commas.csv.gz", "nul_line.txt.gz"}));
}

// Binary JSON (.bgeo) with a uniform int8 array of 200 MB: a byte of the file that would become
// a double. Skipped (under a key the reader ignores) it is never decoded; kept (a point
// attribute's values) it is refused before it is, at the limit.
TEST(Safety, BinaryJsonArraysAreSkippedUndecodedAndDecodedWithinTheLimit) {
  TempDir t;
  const std::string d = t.path.string() + "/";
  const auto key = [](const std::string& s) { return "\x27" + std::string(1, char(s.size())) + s; };
  const std::string array = std::string("\x40\x11\xF4", 3) + std::string("\x00\x00\x80\x0C", 4);  // 200 MiB of int8
  write_gzip_bomb(t.path / "skipped.bgeo.gz", std::string("\x7FNSJb[", 6) + key("info") + "{" + key("a") + array, '\0',
                  200);
  write_gzip_bomb(t.path / "kept.bgeo.gz",
                  std::string("\x7FNSJb[", 6) + key("attributes") + "[" + key("pointattributes") + "[[[" + key("name") +
                      key("P") + key("type") + key("numeric") + "][" + key("values") + "[" + key("tuples") + "[" + array,
                  '\0', 200);
  expect_refused_within("surface " + d + "skipped.bgeo.gz -o " + d + "m.ply", 0.3, "expected a binary JSON token");
  expect_refused_within("surface " + d + "kept.bgeo.gz -o " + d + "m.ply", 0.3, "numbers decoded up to");
}

TEST(Safety, ParticlesAndFieldsPastTheLimitAreRefusedBeforeTheyAreHeld) {
  TempDir t;
  const std::string d = t.path.string() + "/";
  {  // 4 million particles of text, 96 MB of particles and their columns more than the file's 40 MB
    std::ofstream out(t.path / "big.csv");
    out << "x,y,z\n";
    const std::string row = "0.5,0.25,1\n";
    for (int i = 0; i < 4000000; ++i) out << row;
  }
  expect_refused_within("surface " + d + "big.csv -o " + d + "m.ply", 0.1, "particles of 3 values take");
  expect_refused_within("surface " + test::data_file("dam_break_frame_23_24389_particles.bgeo") + " -o " + d +
                            "m.ply --detail 4",
                        0.06, "would need about");
}

TEST(Safety, AbsurdOptionsAreRefusedAtOnce) {
  TempDir t;
  const std::string out = " -o " + t.file("m.ply");
  const std::vector<std::tuple<std::string, int, std::string>> cases = {
      {"surface " + small_frame() + out + " --threads 2000000000", 2, "--threads 2000000000: must be a whole number"},
      {"surface " + small_frame() + out + " --steps-a 2000000000", 2, "--steps-a 2000000000: must be a whole number"},
      {"surface " + small_frame() + out + " --steps-b 10001", 2, "from 0 to 10000"},
      {"surface " + small_frame() + out + " --jobs 2000000000", 2, "--jobs 2000000000: must be"},
      {"surface " + small_frame() + out + " --max-memory 1e300", 2, "--max-memory 1e300: must be"},
      {"surface " + small_frame() + out + " --detail 1000", 2, "--detail 1000: must be a number > 0 and ≤ 8"},
      {"render " + small_frame() + " -o " + t.file("r.png") + " --size 8192x8192 --turntable 64", 2,
       "million pixels: at most"},
      {"render " + small_frame() + " -o " + t.file("r.png") + " --size 8192x8192 --max-memory 0.05", 1,
       "the picture would need"},
  };
  for (const auto& [args, status, says] : cases) {
    const test::Measured r = test::run_measured(meniscus(args));
    EXPECT_EQ(r.status, status) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << args << "\n" << r.output;
    EXPECT_LT(r.seconds, 5) << args;
    if (!test::kSanitized) {
      EXPECT_LT(r.peak_bytes, 150e6) << args;
    }
  }
  EXPECT_TRUE(listing(t.path, true).empty());
}

// --- messages -------------------------------------------------------------------------------------

TEST(Safety, BytesQuotedFromAFileCannotDriveTheTerminal) {
  TempDir t;
  // A garbage line that would clear the screen, retitle the window and ring the bell.
  spit(t.path / "evil.vtk", "# vtk DataFile Version 3.0\nparticles\nASCII\nDATASET POLYDATA\n"
                            "\x1b[2J\x1b]0;owned\x07 \x9b" "31m POINTS 1 float\n0 0 0\n");
  const test::Measured r = test::run_measured(meniscus("surface " + t.file("evil.vtk") + " -o " + t.file("m.ply")));
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_EQ(r.output.find('\x1b'), std::string::npos) << "a raw ESC reached the terminal";
  EXPECT_EQ(r.output.find('\x07'), std::string::npos);
  EXPECT_EQ(r.output.find('\x9b'), std::string::npos);
  EXPECT_NE(r.output.find("\\x1b[2J"), std::string::npos) << r.output;
}

TEST(Safety, ArgumentsQuotedInUsageErrorsCannotDriveTheTerminalAndCarryThePrefix) {
  TempDir t;
  // A file name picked up by a glob, an option's value, an unknown command: each quoted escaped,
  // each one line behind the program's prefix, exit 2.
  const std::string evil = "'" + t.file("a\x1b[2J\x1b]0;owned\x07.ply") + "'";
  for (const std::string& args :
       {"surface " + small_frame() + " " + evil + " -o " + t.file("m.ply"),
        "surface " + small_frame() + " -o " + t.file("m.ply") + " --jobs '\x1b]0;owned\x07'",
        "surface " + small_frame() + " -o " + t.file("m.ply") + " --frames",
        std::string("surfac\x1b[2J"), std::string("")}) {
    const test::Measured r = test::run_measured(meniscus(args));
    EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
    EXPECT_EQ(r.output.find('\x1b'), std::string::npos) << "a raw ESC reached the terminal: " << args;
    EXPECT_EQ(r.output.find('\x07'), std::string::npos) << args;
    EXPECT_EQ(r.output.rfind("meniscus: error: ", 0), 0u) << args << "\n" << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << args << "\n" << r.output;
  }
}

TEST(Safety, MessagesNameTheCliOptionsAndReadAsPlainNumbers) {
  TempDir t;
  const std::string d = t.path.string() + "/";
  spit(t.path / "nan.csv", "x,y,z\n0,0,0\nnan,0,0\n1,1,1\n");
  spit(t.path / "headerless.txt", "0 0 0\n1 1 1\n");
  std::string far = "x,y,z\n", tiny = "x,y,z\n";
  for (int i = 0; i < 512; ++i) {
    const double x = i % 8 * 0.05, y = i / 8 % 8 * 0.05, z = i / 64 * 0.05;
    far += fmt::format("{},{},{}\n", x, y, z);
    tiny += fmt::format("{},{},{}\n", x * 1e-30, y * 1e-30, z * 1e-30);
  }
  far += "1e30,0,0\n";
  spit(t.path / "far.csv", far);
  spit(t.path / "tiny.csv", tiny);
  spit(t.path / "big.json", "{\"spacing\": 1e400}");
  spit(t.path / "twice.json", "{\"steps_a\": 3, \"steps_a\": 4}");
  spit(t.path / "trailing.json", "{\"steps_a\": 3} {\"steps_b\": 4}");
  const std::vector<std::tuple<std::string, int, std::string>> cases = {
      {"surface " + d + "nan.csv -o " + d + "m.ply", 1, "(--drop-invalid drops such particles)"},
      {"surface " + d + "headerless.txt -o " + d + "m.ply", 1, "give --columns x,y,z,..."},
      {"surface " + d + "far.csv -o " + d + "m.ply", 1, "particle 512 lies at (1e+30, 0, 0)"},
      {"surface " + d + "tiny.csv -o " + d + "m.ply", 1, "scale the scene up"},
      {"surface " + d + "far.csv -o " + d + "m.ply --config " + d + "big.json", 2,
       "the number 1e400 is beyond the range of a double"},
      {"surface " + d + "far.csv -o " + d + "m.ply --config " + d + "twice.json", 2, "line 1: the key \"steps_a\" is given twice"},
      {"surface " + d + "far.csv -o " + d + "m.ply --config " + d + "trailing.json", 2, "malformed JSON"},
      {"surface " + small_frame() + " -o " + d + "m.ply --max-memory 0.00001 --voxel-size 0.001", 1,
       "more than the 10.0 KB that --max-memory 1e-05 allows"},
  };
  for (const auto& [args, status, says] : cases) {
    const test::Measured r = test::run_measured(meniscus(args));
    EXPECT_EQ(r.status, status) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << args << "\n" << r.output;
    for (const char* internal : {"ReadOptions::", "json.exception", "hash grid", "0.0 GB", "e+308", "Params::"})
      EXPECT_EQ(r.output.find(internal), std::string::npos) << args << ": '" << internal << "' in\n" << r.output;
  }
}

TEST(Safety, ExitCodesFollowTheTable) {
  TempDir t;
  const std::string d = t.path.string() + "/";
  spit(t.path / "corrupt.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty float x\nend_header\n");
  const std::vector<std::pair<std::string, int>> cases = {
      {"surface " + small_frame() + " -q -o " + d + "ok.ply", 0},
      {"info", 0},
      {"surface --help", 0},
      {"surface " + small_frame() + " -o " + d + "m.ply --smoothnes 0.7", 2},  // an unknown option
      {"surfce " + small_frame(), 2},                                          // an unknown command
      {"surface " + small_frame() + " -o " + d + "m.ply --relax 7", 2},        // a value out of range
      {"surface " + small_frame() + " -o " + d + "m.xyz", 2},                  // no mesh format
      {"surface " + small_frame() + " -o " + small_frame(), 2},                // would overwrite the input
      {"surface " + d + "missing.ply -o " + d + "m.ply", 1},                   // no such file
      {"surface " + d + "corrupt.ply -o " + d + "m.ply", 1},                   // bad input
      {"surface " + q(d + "none_####.ply") + " -o " + q(d + "m_####.ply"), 1}, // no frame exists
      {"inspect " + small_frame(), 1},                                         // particles, not a mesh
      {"surface " + small_frame() + " -o " + d + "m.ply --max-memory 0.001", 1},  // the work needs more memory
  };
  for (const auto& [args, status] : cases) {
    const test::Measured r = test::run_measured(meniscus(args));
    EXPECT_EQ(r.status, status) << args << "\n" << r.output;
  }
}

}  // namespace
}  // namespace meniscus
