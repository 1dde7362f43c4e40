// meniscus tests — decoding PNG files with an independent decoder (stb_image), to check what
// write_png and `meniscus render` wrote.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "meniscus/render.hpp"

namespace meniscus::test {

/// The RGB pixels of PNG bytes; an empty Image (width 0) when they do not decode.
Image decode_png(std::span<const uint8_t> bytes);
/// decode_png of a file's contents (empty Image when it cannot be read).
Image read_png(const std::string& path);

}  // namespace meniscus::test
