// meniscus io — whole-file reads, gzip inflation and the bounds-checked byte cursor.
#include "io/file_bytes.hpp"

#include <algorithm>
#include <cstring>
#include <cerrno>
#include <fcntl.h>
#include <limits>
#include <sys/stat.h>
#include <system_error>
#include <unistd.h>
#include <sys/mman.h>
#include <zlib.h>

#include <fmt/format.h>

#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"

namespace meniscus::io {

namespace {

std::string errno_text(int error) { return std::error_code(error, std::generic_category()).message(); }

// Closes the descriptor on every path out of the readers, exceptions included.
struct FileDescriptor {
  int fd = -1;
  explicit FileDescriptor(int descriptor) : fd(descriptor) {}
  ~FileDescriptor() {
    if (fd >= 0) ::close(fd);
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
};

constexpr std::size_t kChunk = std::size_t(1) << 20;

/// read(2) until `size` bytes or the end; the count read.
std::size_t read_some(int fd, const std::string& path, uint8_t* into, std::size_t size) {
  std::size_t used = 0;
  while (used < size) {
    const ssize_t n = ::read(fd, into + used, size - used);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(fmt::format("cannot read '{}': {}", path, errno_text(errno)));
    }
    if (n == 0) break;
    used += std::size_t(n);
  }
  return used;
}

[[noreturn]] void too_large(const std::string& path, const ReadLimit& limit, const std::string& what) {
  throw ResourceError(fmt::format("'{}' {}: more than {}", printable(path), what, limit.description.empty()
                                      ? fmt::format("the {} allowed", human_bytes(double(limit.bytes)))
                                      : limit.description));
}

/// Inflates gzip members into a ByteBuffer as the compressed bytes arrive (several members back
/// to back, as `cat a.gz b.gz` makes them; trailing bytes that are no member are ignored, as
/// gzip(1) ignores them), refusing to hold more than the limit.
class Inflater {
 public:
  Inflater(const std::string& path, const ReadLimit& limit, std::size_t size_hint) : path_(path), limit_(limit) {
    // 16 + MAX_WBITS: gzip wrapper only, so a zlib or raw stream is reported instead of guessed at.
    if (inflateInit2(&stream_, 16 + MAX_WBITS) != Z_OK)
      throw IoError(fmt::format("cannot decompress '{}': zlib initialisation failed", path));
    const std::size_t first = std::max(kChunk, size_hint);
    out_.reserve(limit.bytes ? std::min(first, limit.bytes) : first);
  }
  ~Inflater() { inflateEnd(&stream_); }
  Inflater(const Inflater&) = delete;
  Inflater& operator=(const Inflater&) = delete;

  /// Inflates the next compressed bytes; `file_size` (0: unknown) is for messages.
  void feed(ByteView in, std::size_t file_size) {
    for (std::size_t at = 0; at < in.size() && !ignoring_;) {
      // zlib counts in uInt: at most 1 GiB of input at a time.
      const std::size_t n = std::min<std::size_t>(in.size() - at, std::size_t(1) << 30);
      stream_.next_in = const_cast<Bytef*>(in.data() + at);  // zlib's API is not const-correct
      stream_.avail_in = static_cast<uInt>(n);
      while (stream_.avail_in > 0 && !ignoring_) step(file_size);
      at += n;
    }
  }

  /// The inflated bytes, once the input has ended.
  ByteBuffer finish() {
    // Between members (or in bytes after the last that are no member) the stream may end.
    if (!between_members_ && !ignoring_)
      throw FormatError(path_, fmt::format("byte {}", consumed_),
                        "expected more gzip-compressed data, the stream is truncated");
    out_.resize(used_);
    return std::move(out_);
  }

 private:
  void step(std::size_t file_size) {
    if (used_ == out_.size()) grow(file_size);
    const std::size_t space = std::min<std::size_t>(out_.size() - used_, std::size_t(1) << 30);
    stream_.next_out = out_.data() + used_;
    stream_.avail_out = static_cast<uInt>(space);
    const uInt in_before = stream_.avail_in;
    const int status = inflate(&stream_, Z_NO_FLUSH);
    const std::size_t eaten = in_before - stream_.avail_in;
    used_ += space - stream_.avail_out;
    consumed_ += eaten;
    member_in_ += eaten;
    if (status == Z_STREAM_END) {
      if (inflateReset(&stream_) != Z_OK)
        throw FormatError(path_, fmt::format("byte {}", consumed_), "cannot restart the gzip decoder");
      between_members_ = true;
      member_in_ = 0;
      return;
    }
    // zlib checks a member's magic on its first two bytes: an error there, after a member, means
    // the bytes that follow are not another member.
    if (status == Z_DATA_ERROR && between_members_ && member_in_ <= 2) {
      ignoring_ = true;
      return;
    }
    if (status != Z_OK && status != Z_BUF_ERROR)
      throw FormatError(path_, fmt::format("byte {}", consumed_),
                        fmt::format("expected valid gzip data ({})", stream_.msg ? stream_.msg : "zlib error"));
    if (member_in_ > 2) between_members_ = false;
  }

  void grow(std::size_t file_size) {
    if (limit_.bytes && used_ >= limit_.bytes)
      too_large(path_, limit_, fmt::format("inflates past {} ({} of its {} read)", human_bytes(double(limit_.bytes)),
                                           human_bytes(double(consumed_)),
                                           file_size ? human_bytes(double(file_size)) : std::string("compressed bytes")));
    std::size_t next = std::max(kChunk, 2 * out_.size());
    if (limit_.bytes) next = std::min(next, limit_.bytes);
    out_.resize(next);  // address space; a page costs memory once written
  }

  std::string path_;
  ReadLimit limit_;
  z_stream stream_{};
  ByteBuffer out_;
  std::size_t used_ = 0, consumed_ = 0, member_in_ = 0;
  bool between_members_ = false;  // a member has ended and the next has not shown its header yet
  bool ignoring_ = false;         // what follows the last member is not one: ignored
};

}  // namespace

ByteBuffer::~ByteBuffer() {
  if (data_) ::munmap(data_, capacity_);
}

ByteBuffer::ByteBuffer(ByteBuffer&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)),
      capacity_(std::exchange(other.capacity_, 0)), touched_(std::exchange(other.touched_, 0)) {}

ByteBuffer& ByteBuffer::operator=(ByteBuffer&& other) noexcept {
  if (this != &other) {
    if (data_) ::munmap(data_, capacity_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    capacity_ = std::exchange(other.capacity_, 0);
    touched_ = std::exchange(other.touched_, 0);
  }
  return *this;
}

void ByteBuffer::reserve(std::size_t capacity) {
  if (capacity <= capacity_) return;
  const std::size_t page = std::size_t(::sysconf(_SC_PAGESIZE));
  const std::size_t rounded = (capacity + page - 1) / page * page;
  void* p = data_ == nullptr ? ::mmap(nullptr, rounded, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0)
                             : ::mremap(data_, capacity_, rounded, MREMAP_MAYMOVE);
  if (p == MAP_FAILED)
    throw ResourceError(fmt::format("cannot hold {} in memory: {}", human_bytes(double(capacity)), errno_text(errno)));
  data_ = static_cast<uint8_t*>(p);
  capacity_ = rounded;
}

void ByteBuffer::resize(std::size_t size) {
  if (size > capacity_) reserve(std::max(size, capacity_ * 2));
  // Pages beyond any size this buffer had are fresh and zero (and cost nothing until written);
  // bytes given up by a shrink are zeroed again when they come back.
  if (size > size_ && size_ < touched_) std::memset(data_ + size_, 0, std::min(size, touched_) - size_);
  size_ = size;
  touched_ = std::max(touched_, size);
}

namespace {

/// The rest of an open file after the `head` bytes already read, whole, within `limit`.
ByteBuffer read_whole(const FileDescriptor& file, const std::string& path, const ReadLimit& limit, ByteView head) {
  struct stat info {};
  const bool regular = ::fstat(file.fd, &info) == 0 && S_ISREG(info.st_mode);
  if (regular && limit.bytes && std::size_t(info.st_size) > limit.bytes)
    too_large(path, limit, fmt::format("holds {}", human_bytes(double(info.st_size))));
  ByteBuffer bytes;
  // The size from fstat is only a first capacity: pipes and /proc files report 0 or lie, so the
  // loop reads until the end of the file whatever it said.
  bytes.reserve(regular && info.st_size > 0 ? std::size_t(info.st_size) + 1 : kChunk);
  bytes.resize(head.size());
  if (!head.empty()) std::memcpy(bytes.data(), head.data(), head.size());
  std::size_t used = head.size();
  for (;;) {
    if (limit.bytes && used > limit.bytes)
      too_large(path, limit, fmt::format("goes on past {}", human_bytes(double(limit.bytes))));
    const std::size_t want = limit.bytes ? std::min(kChunk, limit.bytes + 1 - used) : kChunk;
    bytes.resize(used + want);
    const std::size_t n = read_some(file.fd, path, bytes.data() + used, want);
    used += n;
    if (n < want) break;
  }
  if (limit.bytes && used > limit.bytes)
    too_large(path, limit, fmt::format("goes on past {}", human_bytes(double(limit.bytes))));
  bytes.resize(used);
  return bytes;
}

FileDescriptor open_for_reading(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw IoError(fmt::format("cannot open '{}': {}", path, errno_text(errno)));
  return FileDescriptor(fd);
}

}  // namespace

ByteBuffer read_file_bytes(const std::string& path, const ReadLimit& limit) {
  const FileDescriptor file = open_for_reading(path);
  return read_whole(file, path, limit, {});
}

bool is_gzip(ByteView bytes) { return bytes.size() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b; }

ByteBuffer gunzip(ByteView compressed, const std::string& path, const ReadLimit& limit) {
  // The trailer's ISIZE (size mod 2^32) is a good first capacity; deflate cannot expand more than
  // ~1032:1, which bounds it for a hostile trailer.
  std::size_t hint = 0;
  if (compressed.size() >= 18)
    hint = std::min<std::size_t>(ByteCursor::load<uint32_t>(compressed.data() + compressed.size() - 4, Endian::little),
                                 compressed.size() * 1032);
  Inflater inflater(path, limit, hint);
  inflater.feed(compressed, compressed.size());
  return inflater.finish();
}

ByteBuffer read_file_content(const std::string& path, const ReadLimit& limit, bool* was_gzip) {
  const FileDescriptor file = open_for_reading(path);
  uint8_t magic[2] = {0, 0};
  const std::size_t head = read_some(file.fd, path, magic, 2);
  const bool gz = head == 2 && is_gzip(ByteView(magic, 2));
  if (was_gzip) *was_gzip = gz;
  if (!gz) return read_whole(file, path, limit, ByteView(magic, head));
  struct stat info {};
  const std::size_t file_size = ::fstat(file.fd, &info) == 0 && S_ISREG(info.st_mode) ? std::size_t(info.st_size) : 0;
  // gzip: the trailer's ISIZE (a regular file's last 4 bytes) is the first capacity.
  std::size_t hint = 0;
  if (file_size >= 18) {
    uint8_t trailer[4];
    if (::pread(file.fd, trailer, 4, off_t(file_size - 4)) == 4)
      hint = std::min<std::size_t>(ByteCursor::load<uint32_t>(trailer, Endian::little), file_size * 1032);
  }
  Inflater inflater(path, limit, hint);
  inflater.feed(ByteView(magic, 2), file_size);
  std::vector<uint8_t> chunk(kChunk);
  for (;;) {
    const std::size_t n = read_some(file.fd, path, chunk.data(), chunk.size());
    inflater.feed(ByteView(chunk.data(), n), file_size);
    if (n < chunk.size()) break;
  }
  return inflater.finish();
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
