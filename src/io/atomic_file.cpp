// meniscus io — the atomic, durable output file (see atomic_file.hpp for the guarantees).
#include "io/atomic_file.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <dirent.h>
#include <fcntl.h>
#include <filesystem>
#include <mutex>
#include <random>
#include <set>
#include <sys/stat.h>
#include <system_error>
#include <unistd.h>
#include <zlib.h>

#include <fmt/format.h>

#include "meniscus/errors.hpp"

namespace meniscus::io {

namespace {

constexpr std::size_t kBufferCapacity = std::size_t(1) << 20;
constexpr std::string_view kMarker = ".meniscus-tmp-";
// Long names are shortened in the temporary's name so that it stays under NAME_MAX (255).
constexpr std::size_t kNameInTemporary = 120;

std::string errno_text(int error) { return std::error_code(error, std::generic_category()).message(); }

uint64_t random_suffix() {
  thread_local std::mt19937_64 rng{std::random_device{}()};
  return rng();
}

/// This machine's name as it appears in temporaries: letters, digits, '.' and '_' only.
const std::string& host_tag() {
  static const std::string tag = [] {
    std::array<char, 256> name{};
    std::string out;
    if (::gethostname(name.data(), name.size() - 1) == 0)
      for (const char c : std::string_view(name.data()))
        if (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_') out += c;
    return out.empty() ? std::string("host") : out.substr(0, 64);
  }();
  return tag;
}

struct TemporaryName {
  std::string_view host;
  long pid = 0;
};

/// The host and process of a temporary's name ("<...>.meniscus-tmp-<host>-<pid>-<16 hex>").
bool parse_temporary(std::string_view name, TemporaryName* out) {
  if (name.empty() || name[0] != '.') return false;
  const std::size_t marker = name.rfind(kMarker);
  if (marker == std::string_view::npos || marker == 0) return false;
  std::string_view rest = name.substr(marker + kMarker.size());
  const std::size_t last = rest.rfind('-');
  if (last == std::string_view::npos || rest.size() - last - 1 != 16) return false;
  if (rest.substr(last + 1).find_first_not_of("0123456789abcdef") != std::string_view::npos) return false;
  rest = rest.substr(0, last);
  const std::size_t dash = rest.rfind('-');
  if (dash == std::string_view::npos || dash == 0 || dash + 1 == rest.size()) return false;
  const std::string_view pid = rest.substr(dash + 1);
  if (pid.size() > 9 || pid.find_first_not_of("0123456789") != std::string_view::npos) return false;
  if (out) {
    out->host = rest.substr(0, dash);
    out->pid = std::stol(std::string(pid));
  }
  return true;
}

/// Removes the temporaries in `dir` of processes of this host that are gone (killed mid-write):
/// once per folder and process.
void remove_stale_temporaries(const std::filesystem::path& dir) {
  static std::mutex mutex;
  static std::set<std::string> cleaned;
  {
    std::error_code ec;
    const std::string key = std::filesystem::absolute(dir, ec).string();
    std::lock_guard lock(mutex);
    if (!cleaned.insert(key).second) return;
  }
  DIR* listing = ::opendir(dir.c_str());
  if (listing == nullptr) return;
  const long self = long(::getpid());
  while (const dirent* entry = ::readdir(listing)) {
    TemporaryName t;
    if (!parse_temporary(entry->d_name, &t) || t.host != host_tag() || t.pid == self) continue;
    if (::kill(pid_t(t.pid), 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to judge
    ::unlinkat(::dirfd(listing), entry->d_name, 0);
  }
  ::closedir(listing);
}

// The live temporaries, for the signal handler: fixed slots it can read without locks or
// allocation. state: 0 free, 1 being filled, 2 holds a path.
constexpr int kSlots = 64;
struct Slot {
  std::atomic<int> state{0};
  char path[PATH_MAX];
};
Slot g_slots[kSlots];

int register_temporary(const std::string& path) {
  if (path.size() >= PATH_MAX) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (!g_slots[i].state.compare_exchange_strong(expected, 1)) continue;
    std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
    g_slots[i].state.store(2, std::memory_order_release);
    return i;
  }
  return -1;  // all taken: a stale temporary for a later run to remove, if killed now
}

void unregister_temporary(int slot) {
  if (slot >= 0) g_slots[slot].state.store(0, std::memory_order_release);
}

extern "C" void remove_temporaries_and_end(int signal) {
  for (Slot& slot : g_slots)
    if (slot.state.load(std::memory_order_acquire) == 2) ::unlink(slot.path);
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}

}  // namespace

std::string follow_symlinks(const std::string& path) {
  // A device, pipe or socket is written in place through the name given: the kernel resolves
  // /dev/stdout and /proc/self/fd/N, whose link text ("pipe:[1234]") is no path.
  struct stat resolved {};
  if (::stat(path.c_str(), &resolved) == 0 && !S_ISREG(resolved.st_mode) && !S_ISDIR(resolved.st_mode)) return path;
  std::filesystem::path p(path);
  for (int hop = 0; hop < 40; ++hop) {
    struct stat info {};
    if (::lstat(p.c_str(), &info) != 0 || !S_ISLNK(info.st_mode)) return p.string();
    std::array<char, PATH_MAX> link{};
    const ssize_t n = ::readlink(p.c_str(), link.data(), link.size() - 1);
    if (n < 0) return p.string();
    const std::filesystem::path to(std::string(link.data(), std::size_t(n)));
    p = to.is_absolute() ? to : p.parent_path() / to;
  }
  throw IoError(fmt::format("cannot write '{}': too many levels of symbolic links", path));
}

bool is_temporary_name(std::string_view name) { return parse_temporary(name, nullptr); }

void remove_temporaries_on_signals() {
  for (const int signal : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction action {};
    action.sa_handler = remove_temporaries_and_end;
    sigemptyset(&action.sa_mask);
    ::sigaction(signal, &action, nullptr);
  }
}

struct AtomicFile::Deflate {
  z_stream z{};
  std::vector<char> out = std::vector<char>(std::size_t(1) << 18);
  ~Deflate() { deflateEnd(&z); }
};

AtomicFile::AtomicFile(std::string target, Compression compression) : target_(std::move(target)) {
  const std::string name = std::filesystem::path(target_).filename().string();
  if (name.empty() || name == "." || name == "..")
    throw IoError(fmt::format("cannot write '{}': not a file name", target_));
  destination_ = follow_symlinks(target_);
  const std::filesystem::path destination(destination_);
  const std::filesystem::path dir = destination.has_parent_path() ? destination.parent_path() : std::filesystem::path(".");

  struct stat existing {};
  const bool exists = ::stat(destination_.c_str(), &existing) == 0;
  if (exists && S_ISDIR(existing.st_mode)) throw IoError(fmt::format("cannot write '{}': it is a folder", target_));
  if (exists && !S_ISREG(existing.st_mode)) {
    // A device or a pipe: written in place, as a shell redirection would.
    fd_ = ::open(destination_.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY);
    if (fd_ < 0) throw IoError(fmt::format("cannot write '{}': {}", target_, errno_text(errno)));
  } else {
    remove_stale_temporaries(dir);
    const std::string short_name = destination.filename().string().substr(0, kNameInTemporary);
    // O_EXCL makes a name collision (another writer) an EEXIST we retry, never a shared file.
    for (int attempt = 0;; ++attempt) {
      temp_ = (dir / fmt::format(".{}{}{}-{}-{:016x}", short_name, kMarker, host_tag(), ::getpid(), random_suffix()))
                  .string();
      fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
      if (fd_ >= 0) break;
      const int error = errno;
      if ((error == EEXIST || error == EINTR) && attempt < 16) continue;
      temp_.clear();
      throw IoError(fmt::format("cannot write '{}': cannot create a temporary file in '{}': {}", target_,
                                dir.string(), errno_text(error)));
    }
    slot_ = register_temporary(temp_);
    if (exists) (void)::fchmod(fd_, existing.st_mode & 07777);  // best effort, as editors do
  }
  buffer_.reserve(kBufferCapacity);

  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (compression == Compression::gzip || (compression == Compression::by_name && lower.ends_with(".gz"))) {
    deflate_ = std::make_unique<Deflate>();
    // 15 + 16: a gzip wrapper (header and CRC trailer) around the deflate stream.
    if (deflateInit2(&deflate_->z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
      deflate_.reset();
      throw IoError(fmt::format("cannot write '{}': zlib could not start", target_));
    }
  }
}

AtomicFile::~AtomicFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
  unregister_temporary(slot_);
}

void AtomicFile::write(const void* data, std::size_t size) {
  if (fd_ < 0) throw IoError(fmt::format("cannot write '{}': the file is already closed", target_));
  if (deflate_)
    deflate_some(static_cast<const char*>(data), size, false);
  else
    write_plain(static_cast<const char*>(data), size);
}

void AtomicFile::write_plain(const char* bytes, std::size_t size) {
  if (buffer_.size() + size > kBufferCapacity) flush_buffer();
  if (size >= kBufferCapacity) {
    write_all(bytes, size);
    return;
  }
  buffer_.insert(buffer_.end(), bytes, bytes + size);
}

void AtomicFile::deflate_some(const char* data, std::size_t size, bool finish) {
  z_stream& z = deflate_->z;
  std::size_t at = 0;
  for (;;) {
    // zlib counts in uInt: at most 1 GiB of input at a time.
    const std::size_t in = std::min<std::size_t>(size - at, std::size_t(1) << 30);
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data + at));  // zlib's API is not const-correct
    z.avail_in = uInt(in);
    const bool last = finish && at + in == size;
    int status = Z_OK;
    do {
      z.next_out = reinterpret_cast<Bytef*>(deflate_->out.data());
      z.avail_out = uInt(deflate_->out.size());
      status = deflate(&z, last ? Z_FINISH : Z_NO_FLUSH);
      if (status == Z_STREAM_ERROR) throw IoError(fmt::format("cannot write '{}': zlib failed", target_));
      write_plain(deflate_->out.data(), deflate_->out.size() - z.avail_out);
    } while (z.avail_out == 0 || (last && status != Z_STREAM_END));
    at += in;
    if (at == size) return;
  }
}

void AtomicFile::flush_buffer() {
  write_all(buffer_.data(), buffer_.size());
  buffer_.clear();
}

void AtomicFile::write_all(const char* data, std::size_t size) {
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::write(fd_, data + done, size - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(fmt::format("cannot write '{}': {}", target_, errno_text(errno)));
    }
    done += std::size_t(n);
  }
}

void AtomicFile::close_file() {
  const int fd = fd_;
  fd_ = -1;
  // close() is where NFS and some quota systems report a failed write, so its result matters.
  if (::close(fd) != 0 && errno != EINTR)
    throw IoError(fmt::format("cannot write '{}': {}", target_, errno_text(errno)));
}

void AtomicFile::commit() {
  if (committed_) return;
  if (fd_ < 0) throw IoError(fmt::format("cannot write '{}': the file is already closed", target_));
  if (deflate_) deflate_some(nullptr, 0, true);
  flush_buffer();
  if (temp_.empty()) {  // a device or pipe: nothing to sync or rename
    close_file();
    committed_ = true;
    return;
  }
  // The data reaches the disk before the name does, so a crash after the rename cannot leave an
  // empty or partial file under the target's name.
  if (::fsync(fd_) != 0 && errno != EINVAL)
    throw IoError(fmt::format("cannot write '{}': {}", target_, errno_text(errno)));
  close_file();
  if (std::rename(temp_.c_str(), destination_.c_str()) != 0)
    throw IoError(fmt::format("cannot write '{}': cannot rename the temporary file over it: {}", target_,
                              errno_text(errno)));
  committed_ = true;
  unregister_temporary(slot_);
  slot_ = -1;
  // And the rename itself reaches the disk with its folder.
  const std::filesystem::path destination(destination_);
  const std::string dir = destination.has_parent_path() ? destination.parent_path().string() : std::string(".");
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    const bool synced = ::fsync(dir_fd) == 0 || errno == EINVAL;
    const int error = errno;
    ::close(dir_fd);
    if (!synced) throw IoError(fmt::format("cannot write '{}': cannot sync its folder: {}", target_, errno_text(error)));
  }
}

}  // namespace meniscus::io
