// meniscus io — what the text readers share: lines bounded in length that refuse binary bytes, and short excerpts for messages.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "io/format_registry.hpp"

namespace meniscus::io {

/// The longest line a text reader takes: a header line, a CSV row, an OBJ line, a legacy VTK
/// keyword line, a .npy header. No header or record of the formats read comes near it, so a line
/// that goes on past it is refused there, before anything is made of it.
inline constexpr std::size_t kMaxLineBytes = 16'000'000;

/// The most columns a header may name: CSV columns, PLY elements and properties together, .npy
/// structured fields. What a reader builds per column (names, lookups, empty columns) would
/// otherwise grow with whatever a header claims.
inline constexpr std::size_t kMaxColumns = 1'000'000;

/// The longest tag the VTK XML reader takes (its attributes are held while it is read).
inline constexpr std::size_t kMaxTagBytes = 1'000'000;

/// The bytes no text holds: the C0 control bytes other than tab, line feed, vertical tab, form
/// feed and carriage return, and DEL. Bytes from 0x80 up are UTF-8 or a legacy code page: text.
constexpr bool is_binary_byte(unsigned char c) { return (c < 0x20 && (c < 0x09 || c > 0x0d)) || c == 0x7f; }

/// Where `offset` lies, for messages: "line N, byte M" (lines counted from the start of the
/// bytes, so for errors only), or with `lines` false just the byte (a text part between binary
/// blocks). The byte carries ByteCursor::location's note for inflated bytes.
std::string text_location(const Source& source, std::size_t offset, bool lines = true);

/// Throws FormatError at the first binary byte of source.bytes[from, to), naming its line and
/// offset and quoting a short excerpt from it. For text read token by token (an ASCII PLY body,
/// legacy VTK ASCII values, VTK XML).
void check_text(const Source& source, std::size_t from, std::size_t to, bool lines = true);

/// The end of the line that starts at `start`: the offset of its '\n', or the end of the bytes.
/// Throws FormatError at the line's first binary byte, and at its start when it holds more than
/// kMaxLineBytes: the bytes past either are never looked at.
std::size_t line_end(const Source& source, std::size_t start, bool lines = true);

/// `text` when it holds at most `max` bytes, else its first `max` bytes and "…": what a message
/// quotes of a file (FormatError escapes the control bytes in it).
std::string excerpt(std::string_view text, std::size_t max = 40);

}  // namespace meniscus::io
