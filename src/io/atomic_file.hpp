// meniscus io — all-or-nothing file output: write a temporary file beside the target, rename at commit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace meniscus::io {

/// Writes `target` through a temporary file in the same directory (`.<name>.tmp-<pid>-<random>`)
/// that replaces the target only when commit() succeeds, so readers never see a half-written
/// file and a failed write leaves any previous target untouched. Without commit() (an exception
/// unwinding past it) the destructor removes the temporary file. The data is flushed and every
/// write, close and rename is checked, but not fsync'ed: this protects against failing writes,
/// not against power loss. Every failure throws IoError naming the target. Not thread-safe.
class AtomicFile {
 public:
  /// Creates the temporary file (throws IoError when the directory is missing or not writable).
  explicit AtomicFile(std::string target);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(const void* data, std::size_t size);
  void write(std::string_view text) { write(text.data(), text.size()); }
  void write(std::span<const uint8_t> bytes) { write(bytes.data(), bytes.size()); }

  /// Flushes, closes and renames the temporary file over the target.
  void commit();

  const std::string& target() const { return target_; }
  const std::string& temp_path() const { return temp_; }

 private:
  void flush_buffer();
  void write_all(const char* data, std::size_t size);
  void close_file();

  std::string target_;
  std::string temp_;
  int fd_ = -1;
  bool committed_ = false;
  std::vector<char> buffer_;
};

}  // namespace meniscus::io
