// meniscus — libFuzzer target for one particle reader (MENISCUS_FUZZ_FORMAT names it in the
// format table). Any exception other than the library's own, any crash, leak or sanitizer
// report is a finding.
#include <cstddef>
#include <cstdint>
#include <new>
#include <string>

#include "io/format_registry.hpp"
#include "meniscus/errors.hpp"

namespace {
const meniscus::io::ParticleReader& reader() {
  static const meniscus::io::ParticleReader* r = [] {
    for (const auto& candidate : meniscus::io::particle_readers())
      if (candidate.name == MENISCUS_FUZZ_FORMAT) return &candidate;
    __builtin_trap();  // the target was built for a format the table does not have
  }();
  return *r;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto& r = reader();
  meniscus::io::Source source;
  source.bytes = meniscus::io::ByteView(data, size);
  source.path = std::string("fuzz-input") + (r.extensions.empty() ? "" : r.extensions.front());
  meniscus::ReadOptions options;
  meniscus::ReadReport report;
  try {
    const meniscus::ParticleSet particles = r.read(source, options, &report);
    particles.validate();
  } catch (const meniscus::FormatError&) {
  } catch (const meniscus::InvalidParameter&) {
  } catch (const meniscus::ResourceError&) {
  }
  return 0;
}
