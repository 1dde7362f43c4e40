// meniscus io — bounded text lines, the binary-byte check and message excerpts shared by the text readers.
#include "io/text_lines.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"

namespace meniscus::io {

std::string text_location(const Source& source, std::size_t offset, bool lines) {
  const ByteCursor cursor(source.bytes, source.path, source.gzip);
  const std::size_t end = std::min(offset, source.bytes.size());
  if (!lines) return cursor.location(offset);
  const auto newlines = std::count(source.bytes.begin(), source.bytes.begin() + std::ptrdiff_t(end), uint8_t('\n'));
  return fmt::format("line {}, {}", 1 + newlines, cursor.location(offset));
}

namespace {

[[noreturn]] void binary_byte(const Source& source, std::size_t at, bool lines) {
  const std::string_view text(reinterpret_cast<const char*>(source.bytes.data()), source.bytes.size());
  // The excerpt starts at the byte (a few bytes earlier on its line, for context).
  std::size_t from = at - std::min<std::size_t>(at, 8);
  if (const std::size_t newline = text.rfind('\n', at); newline != std::string_view::npos && newline >= from)
    from = newline + 1;
  throw FormatError(source.path, text_location(source, at, lines),
                    fmt::format("expected text, found the control byte 0x{:02x} in '{}' (binary data in a text "
                                "format: is this the file meant?)",
                                source.bytes[at], excerpt(text.substr(from), 32)));
}

}  // namespace

void check_text(const Source& source, std::size_t from, std::size_t to, bool lines) {
  const uint8_t* bytes = source.bytes.data();
  to = std::min(to, source.bytes.size());
  for (std::size_t i = from; i < to; ++i)
    if (is_binary_byte(bytes[i])) binary_byte(source, i, lines);
}

std::size_t line_end(const Source& source, std::size_t start, bool lines) {
  const uint8_t* bytes = source.bytes.data();
  const std::size_t size = source.bytes.size();
  const std::size_t stop = start + std::min(size - std::min(start, size), kMaxLineBytes);
  for (std::size_t i = start; i < stop; ++i) {
    const uint8_t c = bytes[i];
    if (c == '\n') return i;
    if (is_binary_byte(c)) binary_byte(source, i, lines);
  }
  // kMaxLineBytes read (or the end): a line of exactly that length may still end here.
  if (stop >= size) return size;
  if (bytes[stop] == '\n') return stop;
  throw FormatError(source.path, text_location(source, start, lines),
                    fmt::format("expected a line of at most {} (no header or record of a text format is longer), "
                                "found one that goes on past it: '{}'",
                                human_bytes(double(kMaxLineBytes)),
                                excerpt(std::string_view(reinterpret_cast<const char*>(bytes) + start, 33), 32)));
}

std::string excerpt(std::string_view text, std::size_t max) {
  return text.size() <= max ? std::string(text) : std::string(text.substr(0, max)) + "…";
}

}  // namespace meniscus::io
