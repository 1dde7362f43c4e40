// meniscus — PNG output for preview images: stb_image_write encodes into memory (with zlib's
// deflate), then io::AtomicFile writes them beside the target and renames them into place.
#include <algorithm>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <zlib.h>

#include "io/atomic_file.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/render.hpp"

namespace {

// zlib compresses better and faster than stb's built-in deflate. stb asks for level 8, which on
// rendered images is several times slower than level 6 for barely smaller files, so its request
// is ignored.
// stb frees the buffer with free(), so it must come from malloc(); nullptr reports failure.
unsigned char* zlib_compress(unsigned char* data, int data_length, int* out_length, int /*quality*/) {
  uLongf capacity = compressBound(static_cast<uLong>(data_length));
  auto* out = static_cast<unsigned char*>(std::malloc(capacity));
  if (out == nullptr) return nullptr;
  if (compress2(out, &capacity, data, static_cast<uLong>(data_length), 6) != Z_OK || capacity > uLongf(0x7fffffff)) {
    std::free(out);
    return nullptr;
  }
  *out_length = static_cast<int>(capacity);
  return out;
}

}  // namespace

// Third-party code: compiled with internal linkage (so it cannot clash with another copy) and
// with our warnings off for it alone.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wuseless-cast"  // GCC only
#endif
#pragma GCC diagnostic ignored "-Wold-style-cast"
#define STB_IMAGE_WRITE_STATIC
#define STBI_WRITE_NO_STDIO
#define STBIW_ZLIB_COMPRESS zlib_compress
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>
#pragma GCC diagnostic pop

namespace meniscus {

namespace {

void append_bytes(void* context, void* data, int size) {
  auto* out = static_cast<std::vector<unsigned char>*>(context);
  const auto* bytes = static_cast<const unsigned char*>(data);
  out->insert(out->end(), bytes, bytes + size);
}

}  // namespace

void write_png(const std::string& path, const Image& image) {
  if (image.width < 1 || image.height < 1 ||
      image.rgb.size() != std::size_t(image.width) * std::size_t(image.height) * 3)
    throw InvalidParameter(fmt::format(
        "write_png: image of {} × {} pixels holds {} bytes, expected {}", image.width, image.height, image.rgb.size(),
        std::size_t(std::max(image.width, 0)) * std::size_t(std::max(image.height, 0)) * 3));
  // stb_image_write indexes its filtered copy of the image with int.
  if ((std::size_t(image.width) * 3 + 1) * std::size_t(image.height) > std::size_t(std::numeric_limits<int>::max()))
    throw InvalidParameter(fmt::format("write_png: {} × {} pixels is too large", image.width, image.height));

  std::vector<unsigned char> png;
  if (stbi_write_png_to_func(append_bytes, &png, image.width, image.height, 3, image.rgb.data(), image.width * 3) == 0)
    throw IoError(fmt::format("cannot write '{}': PNG encoding failed", path));

  // Temporary file beside the target, renamed over it only once everything is written.
  io::AtomicFile file(path);
  file.write(png.data(), png.size());
  file.commit();
}

}  // namespace meniscus
