// meniscus io — raw float32 XYZ particle reader.
#include "io/xyz.hpp"

#include <fmt/format.h>

#include "meniscus/errors.hpp"

namespace meniscus::io {

ParticleSet read_xyz_particles(const Source& source, const ReadOptions& /*options*/, ReadReport* report) {
  constexpr std::size_t record = 3 * sizeof(float);
  const std::size_t size = source.bytes.size();
  if (size == 0)
    throw FormatError(source.path, "", "the file is empty, no particles (expected 12-byte float32 x y z records)");
  if (size % record != 0) {
    ByteCursor cursor(source.bytes, source.path, source.gzip);
    cursor.fail_at(size - size % record,
                   fmt::format("file size {} bytes is not a multiple of 12: expected 12-byte float32 x y z "
                               "records, found a trailing partial record of {} byte{}",
                               size, size % record, size % record == 1 ? "" : "s"));
  }
  check_read_memory(source, double(size / record) * sizeof(Vec3f), fmt::format("{} particles", size / record));
  ParticleSet particles;
  particles.positions.resize(size / record);
  const uint8_t* p = source.bytes.data();
  for (Vec3f& position : particles.positions) {
    position.x = ByteCursor::load<float>(p, Endian::little);
    position.y = ByteCursor::load<float>(p + 4, Endian::little);
    position.z = ByteCursor::load<float>(p + 8, Endian::little);
    p += record;
  }
  if (report) report->format = "xyz (raw float32)";
  return particles;
}

}  // namespace meniscus::io
