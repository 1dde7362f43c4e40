// meniscus io — whole-file reads (optionally gunzipped) and a bounds-checked cursor for binary parsing.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace meniscus::io {

using Bytes = std::vector<uint8_t>;
using ByteView = std::span<const uint8_t>;

/// A byte array in an anonymous mapping of its own. Growing it (mremap) never copies and never
/// holds the old and the new block at once, and pages not written yet cost no memory, so a buffer
/// filled up to a bound holds at most the bound: what bounded reading needs. Move-only.
class ByteBuffer {
 public:
  ByteBuffer() = default;
  ~ByteBuffer();
  ByteBuffer(ByteBuffer&& other) noexcept;
  ByteBuffer& operator=(ByteBuffer&& other) noexcept;
  ByteBuffer(const ByteBuffer&) = delete;
  ByteBuffer& operator=(const ByteBuffer&) = delete;

  uint8_t* data() { return data_; }
  const uint8_t* data() const { return data_; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  uint8_t operator[](std::size_t i) const { return data_[i]; }
  const uint8_t* begin() const { return data_; }
  const uint8_t* end() const { return data_ + size_; }
  operator ByteView() const { return {data_, size_}; }

  /// Room for `capacity` bytes, the content kept. Throws ResourceError when the system refuses.
  void reserve(std::size_t capacity);
  /// Grows (new bytes are zero) or shrinks the content; grows the capacity by doubling.
  void resize(std::size_t size);

 private:
  uint8_t* data_ = nullptr;
  std::size_t size_ = 0, capacity_ = 0, touched_ = 0;
};

/// A bound on what a read may hold in memory, and how messages describe it.
struct ReadLimit {
  std::size_t bytes = 0;    ///< 0: none
  std::string description;  ///< completes "more than …": "the 200 MB that --max-memory 0.2 allows"
};

/// The whole content of `path`. Throws IoError naming the file and the system's reason when it
/// cannot be opened or read, ResourceError (file, size, limit) when it holds more than
/// `limit.bytes`: a regular file before anything is read, a pipe or device (/dev/zero) as soon
/// as it passes the bound.
ByteBuffer read_file_bytes(const std::string& path, const ReadLimit& limit = {});

/// True when `bytes` starts with the gzip magic 1f 8b.
bool is_gzip(ByteView bytes);

/// Inflates a gzip stream (concatenated members included). `path` is only used in messages.
/// Throws FormatError (file, compressed byte offset, what zlib expected) on corrupt or truncated
/// input, ResourceError once the inflated bytes would pass `limit`.
ByteBuffer gunzip(ByteView compressed, const std::string& path, const ReadLimit& limit = {});

/// The content of `path`, inflated as it is read when it starts with the gzip magic (never
/// decided by the name): the compressed file is streamed, never held whole, so the bytes held
/// are the inflated ones, at most `limit.bytes`. `*was_gzip` (optional) tells which.
ByteBuffer read_file_content(const std::string& path, const ReadLimit& limit = {}, bool* was_gzip = nullptr);

enum class Endian { little, big };

/// Reads fixed-size values from a byte range. Every read first checks the bytes left and throws
/// FormatError(file, "byte N", "expected <what> ...") instead of reading past the end, so
/// parsers can follow untrusted offsets and counts without their own checks.
class ByteCursor {
 public:
  /// `file` names the source in messages; `decompressed` adds a note that offsets count bytes of
  /// the inflated stream rather than of the file on disk.
  ByteCursor(ByteView bytes, std::string file, bool decompressed = false)
      : bytes_(bytes), file_(std::move(file)), decompressed_(decompressed) {}

  std::size_t offset() const { return offset_; }
  std::size_t remaining() const { return bytes_.size() - offset_; }
  std::size_t size() const { return bytes_.size(); }
  bool at_end() const { return offset_ == bytes_.size(); }
  const std::string& file() const { return file_; }

  /// Moves to an absolute offset (≤ size()).
  void seek(std::size_t offset, std::string_view what);
  /// Skips `count` bytes.
  void skip(std::size_t count, std::string_view what);
  /// The next `count` bytes, consumed.
  ByteView take(std::size_t count, std::string_view what);
  /// Throws unless `count` bytes are left.
  void require(std::size_t count, std::string_view what) const;
  /// Throws unless `count` records of `record_size` bytes are left; overflow-safe, for checking
  /// a header's count before anything is allocated for it.
  void require_records(uint64_t count, std::size_t record_size, std::string_view what) const;

  /// Reads an arithmetic value of type T stored with the given byte order.
  template <class T>
  T read(Endian endian, std::string_view what) {
    static_assert(std::is_arithmetic_v<T>);
    require(sizeof(T), what);
    T value = load<T>(bytes_.data() + offset_, endian);
    offset_ += sizeof(T);
    return value;
  }

  /// Decodes a T at `p` (no bounds check: the caller has called require()).
  template <class T>
  static T load(const uint8_t* p, Endian endian) {
    using U = std::conditional_t<sizeof(T) == 1, uint8_t,
              std::conditional_t<sizeof(T) == 2, uint16_t,
              std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>>;
    static_assert(sizeof(U) == sizeof(T));
    U u = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) {
      const std::size_t shift = endian == Endian::little ? 8 * i : 8 * (sizeof(T) - 1 - i);
      u = static_cast<U>(u | static_cast<U>(static_cast<U>(p[i]) << shift));
    }
    return std::bit_cast<T>(u);
  }

  /// Throws FormatError at the current offset with `message` (e.g. "expected 'ply' magic").
  [[noreturn]] void fail(std::string_view message) const { fail_at(offset_, message); }
  [[noreturn]] void fail_at(std::size_t offset, std::string_view message) const;
  /// "byte N" (or "byte N of the decompressed data").
  std::string location(std::size_t offset) const;

 private:
  ByteView bytes_;
  std::string file_;
  bool decompressed_ = false;
  std::size_t offset_ = 0;
};

}  // namespace meniscus::io
