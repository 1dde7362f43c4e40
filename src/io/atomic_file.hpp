// meniscus io — the one way every output is written: all or nothing, durable, through symlinks.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace meniscus::io {

/// Writes `target` the way an editor saves a file:
/// - A symlink is followed to its target (chains too), which is written; the link stays.
/// - A regular file (or a new one) is written to a hidden temporary beside it
///   (`.<name>.meniscus-tmp-<host>-<pid>-<random>`) that replaces it only at commit(): the data
///   is flushed, fsync'ed, renamed over the target and the folder fsync'ed, so readers and a
///   crash see the old file or the whole new one, never part of one. The new file keeps the
///   permissions of the one it replaces.
/// - A device or pipe (`/dev/stdout`, a FIFO) is written in place: there is nothing to rename.
/// - A name ending in ".gz" (any case) is gzip-compressed on the way, streamed through zlib into
///   the temporary: no uncompressed copy touches the disk.
/// Without commit() (an exception unwinding past it) the destructor removes the temporary. A
/// temporary left by a process that was killed (same host, process gone) is removed by the next
/// AtomicFile created in its folder; remove_temporaries_on_signals() makes SIGINT, SIGTERM and
/// SIGHUP remove the live ones first. Every failure throws IoError naming the target. One
/// AtomicFile is not thread-safe; several may be written at once.
class AtomicFile {
 public:
  enum class Compression { by_name, none, gzip };

  /// Creates the temporary file (IoError when the folder is missing or not writable, or the
  /// target is a folder).
  explicit AtomicFile(std::string target, Compression compression = Compression::by_name);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(const void* data, std::size_t size);
  void write(std::string_view text) { write(text.data(), text.size()); }
  void write(std::span<const uint8_t> bytes) { write(bytes.data(), bytes.size()); }

  /// Finishes the stream, flushes, fsyncs, renames the temporary over the destination.
  void commit();

  /// The path as given.
  const std::string& target() const { return target_; }
  /// The file that is written: `target` with its symlinks followed.
  const std::string& destination() const { return destination_; }
  /// The temporary file; empty when a device or pipe is written in place.
  const std::string& temp_path() const { return temp_; }

 private:
  struct Deflate;
  void write_plain(const char* data, std::size_t size);
  void flush_buffer();
  void write_all(const char* data, std::size_t size);
  void deflate_some(const char* data, std::size_t size, bool finish);
  void close_file();

  std::string target_, destination_, temp_;
  int fd_ = -1;
  int slot_ = -1;  // the signal handler's record of temp_
  bool committed_ = false;
  std::vector<char> buffer_;
  std::unique_ptr<Deflate> deflate_;
};

/// `path` with the symlinks of its last component followed (relative links resolve against the
/// link's folder), as far as they go: the file a write to `path` lands in, existing or not.
/// A path that resolves to a device, pipe or socket is returned as given (a /proc/self/fd link's
/// text names no file). Throws IoError for a loop of links.
std::string follow_symlinks(const std::string& path);

/// Makes SIGINT, SIGTERM and SIGHUP remove every AtomicFile's temporary before the process ends
/// the way the signal ends it. For programs (the CLI); a library leaves signals to its host.
void remove_temporaries_on_signals();

/// Whether `name` (a file name, no folder) is an AtomicFile temporary.
bool is_temporary_name(std::string_view name);

}  // namespace meniscus::io
