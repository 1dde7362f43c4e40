// meniscus io — whole-file reads, gzip inflation and the bounds-checked byte cursor.
#include "io/file_bytes.hpp"

#include <algorithm>
#include <cerrno>
#include <fcntl.h>
#include <limits>
#include <sys/stat.h>
#include <system_error>
#include <unistd.h>
#include <zlib.h>

#include <fmt/format.h>

#include "meniscus/errors.hpp"

namespace meniscus::io {

namespace {

std::string errno_text(int error) { return std::error_code(error, std::generic_category()).message(); }

// Closes the descriptor on every path out of read_file_bytes, exceptions included.
struct FileDescriptor {
  int fd = -1;
  ~FileDescriptor() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

Bytes read_file_bytes(const std::string& path) {
  FileDescriptor file;
  file.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (file.fd < 0) throw IoError(fmt::format("cannot open '{}': {}", path, errno_text(errno)));

  struct stat info {};
  Bytes bytes;
  // The size from fstat is only a capacity hint: pipes and /proc files report 0 or lie, so the
  // loop below reads until end of file whatever the hint said.
  if (::fstat(file.fd, &info) == 0 && S_ISREG(info.st_mode) && info.st_size > 0)
    bytes.reserve(std::size_t(info.st_size) + 1);
  std::size_t used = 0;
  for (;;) {
    if (bytes.size() - used < 65536) bytes.resize(std::max(bytes.capacity(), used + 65536));
    const ssize_t n = ::read(file.fd, bytes.data() + used, bytes.size() - used);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(fmt::format("cannot read '{}': {}", path, errno_text(errno)));
    }
    if (n == 0) break;
    used += std::size_t(n);
  }
  bytes.resize(used);
  return bytes;
}

bool is_gzip(ByteView bytes) { return bytes.size() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b; }

Bytes gunzip(ByteView compressed, const std::string& path) {
  z_stream stream{};
  // 16 + MAX_WBITS: gzip wrapper only, so a zlib or raw stream is reported instead of guessed at.
  if (inflateInit2(&stream, 16 + MAX_WBITS) != Z_OK)
    throw IoError(fmt::format("cannot decompress '{}': zlib initialisation failed", path));
  struct InflateEnd {
    z_stream* s;
    ~InflateEnd() { inflateEnd(s); }
  } end_guard{&stream};

  Bytes out;
  // The trailer's ISIZE (size mod 2^32) is a good first guess; deflate cannot expand more than
  // ~1032:1, which bounds the guess for a hostile trailer.
  if (compressed.size() >= 18) {
    const std::size_t isize = ByteCursor::load<uint32_t>(compressed.data() + compressed.size() - 4, Endian::little);
    const std::size_t ceiling = compressed.size() <= std::numeric_limits<std::size_t>::max() / 1032
                                    ? compressed.size() * 1032 : std::numeric_limits<std::size_t>::max();
    out.reserve(std::min(isize, ceiling));
  }

  std::size_t in_offset = 0;
  std::size_t used = 0;
  for (;;) {
    // zlib counts in uInt; feed at most 1 GiB at a time so large inputs do not truncate.
    constexpr std::size_t chunk = std::size_t(1) << 30;
    if (stream.avail_in == 0 && in_offset < compressed.size()) {
      const std::size_t n = std::min(chunk, compressed.size() - in_offset);
      stream.next_in = const_cast<Bytef*>(compressed.data() + in_offset);  // zlib's API is not const-correct
      stream.avail_in = static_cast<uInt>(n);
      in_offset += n;
    }
    if (out.size() - used < 65536) out.resize(std::max(out.capacity(), used + std::min(used + 65536, chunk)));
    const std::size_t space = std::min(out.size() - used, chunk);
    stream.next_out = out.data() + used;
    stream.avail_out = static_cast<uInt>(space);
    const int status = inflate(&stream, Z_NO_FLUSH);
    used += space - stream.avail_out;
    const std::size_t consumed = in_offset - stream.avail_in;
    if (status == Z_STREAM_END) {
      // A gzip file may hold several members back to back (`cat a.gz b.gz`); anything else after
      // the end is trailing padding, which gzip(1) also ignores.
      const ByteView rest = compressed.subspan(consumed);
      if (!is_gzip(rest)) break;
      if (inflateReset(&stream) != Z_OK)
        throw FormatError(path, fmt::format("byte {}", consumed), "cannot restart the gzip decoder");
      continue;
    }
    if (status == Z_BUF_ERROR && stream.avail_in == 0 && in_offset == compressed.size())
      throw FormatError(path, fmt::format("byte {}", consumed),
                        "expected more gzip-compressed data, the stream is truncated");
    if (status != Z_OK && status != Z_BUF_ERROR)
      throw FormatError(path, fmt::format("byte {}", consumed),
                        fmt::format("expected valid gzip data ({})", stream.msg ? stream.msg : "zlib error"));
  }
  out.resize(used);
  out.shrink_to_fit();
  return out;
}

Bytes read_file_bytes_gunzipped(const std::string& path, bool* was_gzip) {
  Bytes bytes = read_file_bytes(path);
  const bool gz = is_gzip(bytes);
  if (was_gzip) *was_gzip = gz;
  if (!gz) return bytes;
  return gunzip(bytes, path);
}

void ByteCursor::seek(std::size_t offset, std::string_view what) {
  if (offset > bytes_.size())
    fail_at(offset_, fmt::format("expected {} at byte {}, but the data ends at byte {}", what, offset, bytes_.size()));
  offset_ = offset;
}

void ByteCursor::skip(std::size_t count, std::string_view what) {
  require(count, what);
  offset_ += count;
}

ByteView ByteCursor::take(std::size_t count, std::string_view what) {
  require(count, what);
  const ByteView view = bytes_.subspan(offset_, count);
  offset_ += count;
  return view;
}

void ByteCursor::require(std::size_t count, std::string_view what) const {
  if (count > remaining())
    fail(fmt::format("expected {} ({} byte{}), but only {} byte{} left", what, count, count == 1 ? "" : "s",
                     remaining(), remaining() == 1 ? "" : "s"));
}

void ByteCursor::require_records(uint64_t count, std::size_t record_size, std::string_view what) const {
  if (record_size == 0 || count == 0) return;
  if (count > remaining() / record_size)
    fail(fmt::format("expected {} × {} bytes for {}, but only {} bytes are left (the count is larger than the "
                     "file can hold)",
                     count, record_size, what, remaining()));
}

std::string ByteCursor::location(std::size_t offset) const {
  return decompressed_ ? fmt::format("byte {} (of the decompressed data)", offset) : fmt::format("byte {}", offset);
}

void ByteCursor::fail_at(std::size_t offset, std::string_view message) const {
  throw FormatError(file_, location(offset), std::string(message));
}

}  // namespace meniscus::io
