// meniscus io — Houdini ".bgeo.sc" container (Blosc-1 chunks + index; layout as in /work/shared FORMATS.md B, c-blosc 1.x).
//
// Layout: "scf1", 8 zero bytes; k Blosc-1 chunks back to back, each the compression of one
// chunk-size slice of the plain .bgeo stream (the last one shorter); then big-endian uint64s:
// the start of chunks 1 … k−1 relative to byte 12, the chunk size, the uncompressed size of the
// last chunk, the index size (8(k−1) + 16, counting those fields but not itself); then "1fcs".
// Houdini 18.5's chunks (tests/data/houdini_pop_splatter_13883_points.bgeo.sc): 1 MiB, Blosc
// version 2, flags 0x21 (byte shuffle, LZ4), type size 4, block size = chunk size rounded down to
// the type size; the writer asks c-blosc for exactly that.
#include "io/blosc_container.hpp"

#include <blosc.h>

#include <algorithm>
#include <limits>

#include <fmt/format.h>

#include "io/bgeo_json.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/mesh.hpp"

namespace meniscus::io {

namespace {

constexpr std::size_t prefix_size = 12;   // "scf1" + 8 zero bytes
constexpr std::size_t suffix_size = 12;   // index size + "1fcs"
constexpr std::size_t blosc_header = 16;  // BLOSC_MIN_HEADER_LENGTH: version, flags, typesize, nbytes, blocksize, cbytes
// LZ4 cannot expand more than ~255:1; a chunk that claims more is corrupt, and refusing it
// bounds what a hostile header can make us allocate.
constexpr uint64_t max_expansion = 256;

// The writer's settings, Houdini's (see the top of the file). c-blosc turns the level into LZ4's
// acceleration (10 − level), so 9 is LZ4's default, strongest setting.
constexpr std::size_t write_chunk_size = std::size_t(1) << 20;
constexpr int compression_level = 9;
constexpr std::size_t type_size = 4;

void put_be64(Bytes& out, uint64_t v) {
  for (int shift = 56; shift >= 0; shift -= 8) out.push_back(static_cast<uint8_t>(v >> shift));
}

}  // namespace

bool sniff_blosc_container(ByteView bytes) {
  return bytes.size() >= 4 && bytes[0] == 's' && bytes[1] == 'c' && bytes[2] == 'f' && bytes[3] == '1';
}

Bytes decompress_blosc_container(ByteView bytes, const std::string& path, const ReadLimit& limit) {
  ByteCursor c(bytes, path);
  const ByteView magic = c.take(4, "the 'scf1' magic");
  if (!std::equal(magic.begin(), magic.end(), "scf1")) c.fail_at(0, "expected the '.bgeo.sc' magic 'scf1'");
  c.skip(8, "the 8 reserved bytes after 'scf1'");
  if (bytes.size() < prefix_size + suffix_size + 16)
    c.fail_at(bytes.size(), fmt::format("expected at least {} bytes (header, index and '1fcs' trailer), the file has {}",
                                        prefix_size + suffix_size + 16, bytes.size()));
  const std::size_t trailer_at = bytes.size() - 4;
  if (!std::equal(bytes.begin() + std::ptrdiff_t(trailer_at), bytes.end(), "1fcs"))
    c.fail_at(trailer_at, "expected the '1fcs' trailer at the end of the file (the file is truncated or not a .bgeo.sc)");

  const std::size_t index_size_at = bytes.size() - suffix_size;
  c.seek(index_size_at, "the index size");
  const uint64_t index_size = c.read<uint64_t>(Endian::big, "the index size");
  const std::size_t room = index_size_at - prefix_size;
  if (index_size < 16 || index_size % 8 != 0 || index_size > room)
    c.fail_at(index_size_at, fmt::format("expected an index size that is a multiple of 8 from 16 to {}, found {}",
                                         room - room % 8, index_size));
  const std::size_t index_at = index_size_at - std::size_t(index_size);
  const std::size_t chunks = std::size_t(index_size - 16) / 8 + 1;
  c.seek(index_at, "the index");
  std::vector<std::size_t> starts{prefix_size};
  for (std::size_t i = 1; i < chunks; ++i) {
    const std::size_t at = c.offset();
    const uint64_t start = c.read<uint64_t>(Endian::big, "a chunk offset");
    // Each chunk holds at least a Blosc header, so starts grow by at least that much.
    if (start < starts.back() - prefix_size + blosc_header || start > index_at - prefix_size - blosc_header)
      c.fail_at(at, fmt::format("expected chunk {} to start between byte {} and {} after the header, found {}", i,
                                starts.back() - prefix_size + blosc_header, index_at - prefix_size - blosc_header,
                                start));
    starts.push_back(prefix_size + std::size_t(start));
  }
  const std::size_t chunk_size_at = c.offset();
  const uint64_t chunk_size = c.read<uint64_t>(Endian::big, "the chunk size");
  const std::size_t last_size_at = c.offset();
  const uint64_t last_size = c.read<uint64_t>(Endian::big, "the last chunk's size");
  if (chunk_size == 0 || chunk_size > uint64_t(BLOSC_MAX_BUFFERSIZE))
    c.fail_at(chunk_size_at, fmt::format("expected a chunk size from 1 to {}, found {}", BLOSC_MAX_BUFFERSIZE, chunk_size));
  if (last_size > chunk_size)
    c.fail_at(last_size_at, fmt::format("expected the last chunk's size to be at most the chunk size {}, found {}",
                                        chunk_size, last_size));
  starts.push_back(index_at);  // the end of the last chunk

  // Check every chunk's header against the index before allocating the output.
  uint64_t total = 0;
  for (std::size_t i = 0; i < chunks; ++i) {
    const std::size_t begin = starts[i], end = starts[i + 1];
    if (end - begin < blosc_header)
      c.fail_at(begin, fmt::format("expected Blosc chunk {} of at least {} bytes, found {}", i, blosc_header, end - begin));
    const uint8_t* h = bytes.data() + begin;
    const uint64_t nbytes = ByteCursor::load<uint32_t>(h + 4, Endian::little);
    const uint64_t cbytes = ByteCursor::load<uint32_t>(h + 12, Endian::little);
    const uint64_t expected = i + 1 < chunks ? chunk_size : last_size;
    if (cbytes != end - begin)
      c.fail_at(begin, fmt::format("expected Blosc chunk {} to be {} bytes long as the index says, its header says {}",
                                   i, end - begin, cbytes));
    if (nbytes != expected)
      c.fail_at(begin, fmt::format("expected Blosc chunk {} to decompress to {} bytes, its header says {}", i, expected,
                                   nbytes));
    if (nbytes > cbytes * max_expansion)
      c.fail_at(begin, fmt::format("expected Blosc chunk {} to expand at most {}:1, its header claims {} from {} bytes", i,
                                   max_expansion, nbytes, cbytes));
    std::size_t validated = 0;
    if (blosc_cbuffer_validate(h, std::size_t(cbytes), &validated) != 0 || validated != nbytes)
      c.fail_at(begin, fmt::format("expected a valid Blosc-1 chunk header for chunk {}", i));
    total += nbytes;
  }

  if (limit.bytes && double(total) + double(bytes.size()) > double(limit.bytes))
    throw ResourceError(fmt::format("'{}': its Blosc chunks decompress to {} beside the {} read: more than {}",
                                    printable(path), human_bytes(double(total)), human_bytes(double(bytes.size())),
                                    limit.description));
  Bytes out(static_cast<std::size_t>(total));
  std::size_t used = 0;
  for (std::size_t i = 0; i < chunks; ++i) {
    const std::size_t begin = starts[i];
    const std::size_t nbytes = ByteCursor::load<uint32_t>(bytes.data() + begin + 4, Endian::little);
    if (nbytes == 0) continue;
    // blosc_decompress_ctx keeps no global state, so concurrent readers are safe.
    const int n = blosc_decompress_ctx(bytes.data() + begin, out.data() + used, nbytes, 1);
    if (n < 0 || std::size_t(n) != nbytes)
      c.fail_at(begin, fmt::format("expected Blosc chunk {} to decompress to {} bytes, the data is corrupt (blosc "
                                   "returned {})",
                                   i, nbytes, n));
    used += nbytes;
  }
  return out;
}

namespace {

/// What the decompressed stream may hold besides the container's bytes.
ReadLimit inner_limit(const Source& source) {
  ReadLimit inner = source.limit;
  if (inner.bytes) inner.bytes = inner.bytes > source.bytes.size() ? inner.bytes - source.bytes.size() : 1;
  return inner;
}

}  // namespace

ParticleSet read_bgeo_sc_particles(const Source& source, const ReadOptions& options, ReadReport* report) {
  const Bytes plain = decompress_blosc_container(source.bytes, source.path, source.limit);
  const Source inner{plain, source.path, true, inner_limit(source)};
  ParticleSet particles = read_bgeo_json_particles(inner, options, report);
  if (report) report->format = "bgeo.sc (Blosc-compressed binary JSON bgeo)";
  return particles;
}

TriangleMesh read_bgeo_sc_mesh(const Source& source) {
  const Bytes plain = decompress_blosc_container(source.bytes, source.path, source.limit);
  return read_bgeo_json_mesh(Source{plain, source.path, true, inner_limit(source)});
}

BloscContainerWriter::BloscContainerWriter(std::string path) : path_(std::move(path)) { plain_.reserve(write_chunk_size); }

void BloscContainerWriter::write(ByteView bytes) {
  while (!bytes.empty()) {
    const std::size_t take = std::min(bytes.size(), write_chunk_size - plain_.size());
    plain_.insert(plain_.end(), bytes.begin(), bytes.begin() + std::ptrdiff_t(take));
    bytes = bytes.subspan(take);
    if (plain_.size() == write_chunk_size) compress_chunk();
  }
}

void BloscContainerWriter::compress_chunk() {
  if (!file_) {
    file_.emplace(path_);
    file_->write(std::string_view("scf1\0\0\0\0\0\0\0\0", prefix_size));
  }
  compressed_.resize(plain_.size() + BLOSC_MAX_OVERHEAD);
  // One block per chunk (block size = chunk size) as Houdini writes them; the _ctx call keeps no
  // global state, so writers in several threads are safe.
  const int n = blosc_compress_ctx(compression_level, BLOSC_SHUFFLE, type_size, plain_.size(), plain_.data(),
                                   compressed_.data(), compressed_.size(), BLOSC_LZ4_COMPNAME, plain_.size(), 1);
  if (n <= 0)
    throw IoError(fmt::format("cannot write '{}': Blosc could not compress chunk {} (returned {})", path_,
                              chunk_ends_.size(), n));
  file_->write(compressed_.data(), std::size_t(n));
  chunk_ends_.push_back((chunk_ends_.empty() ? 0 : chunk_ends_.back()) + uint64_t(n));
  last_size_ = plain_.size();
  plain_.clear();
}

void BloscContainerWriter::commit() {
  // A stream of whole chunks ends with a full one; an empty stream still gets its (empty) chunk.
  if (!plain_.empty() || chunk_ends_.empty()) compress_chunk();
  Bytes index;
  for (std::size_t i = 0; i + 1 < chunk_ends_.size(); ++i) put_be64(index, chunk_ends_[i]);  // starts of chunks 1 …
  put_be64(index, write_chunk_size);
  put_be64(index, last_size_);
  put_be64(index, 8 * (chunk_ends_.size() - 1) + 16);
  for (const char c : std::string_view("1fcs")) index.push_back(static_cast<uint8_t>(c));
  file_->write(index);
  file_->commit();
}

void write_bgeo_sc_mesh(const std::string& path, const TriangleMesh& mesh) {
  // The encoder checks the whole mesh before its first piece arrives, and the container's file is
  // created with the first chunk: a mesh that cannot be written leaves no file at all.
  BloscContainerWriter out(path);
  encode_bgeo_json_mesh(path, mesh, [&](ByteView bytes) { out.write(bytes); });
  out.commit();
}

}  // namespace meniscus::io
