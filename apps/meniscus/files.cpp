// meniscus CLI — the checks of a run's files before any work, and small output helpers (cli.hpp).
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <filesystem>
#include <map>
#include <system_error>
#include <unordered_map>
#include <utility>

#include "cli.hpp"
#include "io/atomic_file.hpp"
#include "io/file_bytes.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/resources.hpp"

namespace meniscus::cli {

namespace {

std::string quoted(const RunFile& f) { return fmt::format("{} '{}'", f.role, printable(f.path)); }

struct Identity {
  std::string path;  // absolute, symlinks followed, normalised
  bool regular = false, exists = false;
  dev_t device = 0;
  ino_t inode = 0;
};

Identity identify(const RunFile& f) {
  const std::string& given = f.path;
  Identity id;
  std::string followed;
  try {
    followed = io::follow_symlinks(given);
  } catch (const IoError&) {  // a loop of links: an output is a bad option, an input bad input
    if (f.output)
      throw InvalidParameter(fmt::format("{} cannot be written: its symbolic links make a loop", quoted(f)));
    throw IoError(fmt::format("cannot read {}: its symbolic links make a loop", quoted(f)));
  }
  std::error_code ec;
  std::filesystem::path p = std::filesystem::absolute(followed, ec);
  if (!ec) p = std::filesystem::weakly_canonical(p, ec);
  id.path = (ec ? std::filesystem::path(followed) : p).lexically_normal().string();
  struct stat info {};
  if (::stat(followed.c_str(), &info) == 0) {
    id.exists = true;
    id.regular = S_ISREG(info.st_mode);
    id.device = info.st_dev;
    id.inode = info.st_ino;
  }
  return id;
}

/// An output must be writable: not a folder, in a folder that exists (or can be made) and takes
/// new files.
void check_writable(const RunFile& f, const Identity& id) {
  if (id.exists && !id.regular) {
    struct stat info {};
    if (::stat(id.path.c_str(), &info) == 0 && S_ISDIR(info.st_mode))
      throw InvalidParameter(fmt::format("{} is a folder: give a file name", quoted(f)));
    return;  // a device or pipe, written in place
  }
  // The names the final rename will make, checked now rather than after the work.
  const std::string name = std::filesystem::path(id.path).filename().string();
  if (name.size() > NAME_MAX)
    throw InvalidParameter(fmt::format("{} cannot be written: its name is {} bytes long, more than the {} a file name "
                                       "may have", quoted(f), name.size(), NAME_MAX));
  if (id.path.size() >= PATH_MAX)
    throw InvalidParameter(fmt::format("{} cannot be written: its path is {} bytes long, more than the {} a path may "
                                       "have", quoted(f), id.path.size(), PATH_MAX - 1));
  // Like cp without -f: a file that exists and that this user may not write is not replaced
  // (root may, as with cp).
  if (id.exists && ::access(id.path.c_str(), W_OK) != 0 && errno == EACCES)
    throw InvalidParameter(fmt::format("{} is read-only for you: meniscus does not replace it (make it writable, or "
                                       "choose another name)", quoted(f)));
  std::filesystem::path dir = std::filesystem::path(id.path).parent_path();
  std::error_code ec;
  while (!dir.empty() && !std::filesystem::exists(dir, ec) && dir != dir.root_path()) dir = dir.parent_path();
  if (dir.empty()) dir = ".";
  if (!std::filesystem::is_directory(dir, ec))
    throw InvalidParameter(fmt::format("{} cannot be written: '{}' is not a folder", quoted(f), dir.string()));
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw InvalidParameter(fmt::format("{} cannot be written: no new files can be made in '{}' ({})", quoted(f),
                                       dir.string(), std::error_code(errno, std::generic_category()).message()));
}

}  // namespace

void check_run_files(const std::vector<RunFile>& files) {
  std::unordered_map<std::string, std::size_t> by_path;
  std::map<std::pair<dev_t, ino_t>, std::size_t> by_inode;
  for (std::size_t i = 0; i < files.size(); ++i) {
    const RunFile& f = files[i];
    if (f.path.empty()) continue;
    const Identity id = identify(f);
    if (f.output) check_writable(f, id);
    // Devices and pipes (/dev/null, /dev/stdout) may serve several roles: nothing on them is lost.
    if (id.exists && !id.regular) continue;
    std::size_t other = files.size();
    if (const auto it = by_path.find(id.path); it != by_path.end()) other = it->second;
    if (id.exists)
      if (const auto it = by_inode.find({id.device, id.inode}); it != by_inode.end()) other = std::min(other, it->second);
    if (other < files.size()) {
      const RunFile& first = files[other];
      if (!f.output && !first.output) continue;  // reading a file twice harms nothing
      if (f.output && first.output)
        throw InvalidParameter(
            fmt::format("{} is the same file as {}: each output needs its own file", quoted(f), quoted(first)));
      const RunFile& output = f.output ? f : first;
      const RunFile& input = f.output ? first : f;
      throw InvalidParameter(fmt::format("{} is the same file as {}: meniscus never overwrites its input (choose "
                                         "another output)",
                                         quoted(output), quoted(input)));
    }
    by_path.emplace(id.path, i);
    if (id.exists) by_inode.emplace(std::pair{id.device, id.inode}, i);
  }
}

void make_parent_dirs(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(io::follow_symlinks(path)).parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(parent, ec);
  if (ec) throw IoError(fmt::format("{}: cannot create the folder {}: {}", path, parent.string(), ec.message()));
}

void write_text_file(const std::string& path, const std::string& text) {
  io::AtomicFile file(path);
  file.write(text.data(), text.size());
  file.commit();
}

std::string read_text_file(const std::string& path) {
  constexpr std::size_t kMaxText = 64'000'000;
  const io::ByteBuffer bytes =
      io::read_file_bytes(path, {kMaxText, fmt::format("the {} such a text file may hold", human_bytes(kMaxText))});
  return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

void check_output_format(const std::string& output) {
  // Any format may be gzip-compressed: "mesh.bgeo.gz".
  const std::string name = output.size() > 3 && output.compare(output.size() - 3, 3, ".gz") == 0
                               ? output.substr(0, output.size() - 3)
                               : output;
  for (const std::string& ext : mesh_formats())
    if (name.size() >= ext.size() && name.compare(name.size() - ext.size(), ext.size(), ext) == 0) return;
  throw InvalidParameter(fmt::format("output '{}': unknown mesh format (supported: {})", printable(output),
                                     fmt::join(mesh_formats(), ", ")));
}

void print_warning(std::string_view text) { fmt::print(stderr, "warning: {}\n", printable(text)); }

double memory_limit_bytes(double max_memory_gb) { return memory_limit(max_memory_gb).amount; }

}  // namespace meniscus::cli
