// meniscus io — temporary-file-and-rename output (see atomic_file.hpp for the guarantees).
#include "io/atomic_file.hpp"

#include <cerrno>
#include <cstdio>
#include <fcntl.h>
#include <filesystem>
#include <random>
#include <system_error>
#include <unistd.h>

#include <fmt/format.h>

#include "meniscus/errors.hpp"

namespace meniscus::io {

namespace {

constexpr std::size_t buffer_capacity = std::size_t(1) << 20;

std::string errno_text(int error) { return std::error_code(error, std::generic_category()).message(); }

uint64_t random_suffix() {
  thread_local std::mt19937_64 rng{std::random_device{}()};
  return rng();
}

}  // namespace

AtomicFile::AtomicFile(std::string target) : target_(std::move(target)) {
  const std::filesystem::path path(target_);
  const std::string name = path.filename().string();
  if (name.empty() || name == "." || name == "..")
    throw IoError(fmt::format("cannot write '{}': not a file name", target_));
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  // O_EXCL makes a name collision (another writer, a stale file) an EEXIST we can retry, never a
  // shared temporary file.
  for (int attempt = 0;; ++attempt) {
    temp_ = (dir / fmt::format(".{}.tmp-{}-{:016x}", name, ::getpid(), random_suffix())).string();
    fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd_ >= 0) break;
    const int error = errno;
    if ((error == EEXIST || error == EINTR) && attempt < 16) continue;
    temp_.clear();
    throw IoError(fmt::format("cannot write '{}': cannot create a temporary file in '{}': {}", target_,
                              dir.string(), errno_text(error)));
  }
  buffer_.reserve(buffer_capacity);
}

AtomicFile::~AtomicFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicFile::write(const void* data, std::size_t size) {
  if (fd_ < 0) throw IoError(fmt::format("cannot write '{}': the file is already closed", target_));
  const char* bytes = static_cast<const char*>(data);
  if (buffer_.size() + size > buffer_capacity) flush_buffer();
  if (size >= buffer_capacity) {
    write_all(bytes, size);
    return;
  }
  buffer_.insert(buffer_.end(), bytes, bytes + size);
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
  flush_buffer();
  close_file();
  if (std::rename(temp_.c_str(), target_.c_str()) != 0)
    throw IoError(fmt::format("cannot write '{}': cannot rename the temporary file over it: {}", target_,
                              errno_text(errno)));
  committed_ = true;
}

}  // namespace meniscus::io
