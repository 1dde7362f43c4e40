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

/// The whole content of `path`. Throws IoError naming the file and the system's reason when it
/// cannot be opened or read.
Bytes read_file_bytes(const std::string& path);

/// True when `bytes` starts with the gzip magic 1f 8b.
bool is_gzip(ByteView bytes);

/// Inflates a gzip stream (concatenated members included). `path` is only used in messages.
/// Throws FormatError (file, compressed byte offset, what zlib expected) on corrupt or truncated
/// input.
Bytes gunzip(ByteView compressed, const std::string& path);

/// The content of `path`, inflated when it starts with the gzip magic (never decided by the name).
/// `*was_gzip` (optional) tells which.
Bytes read_file_bytes_gunzipped(const std::string& path, bool* was_gzip = nullptr);

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
