// meniscus — libFuzzer target for one particle reader (MENISCUS_FUZZ_FORMAT names it in the
// format table). The reader holds at most kReadLimit (as --max-memory bounds a run), and the
// fuzzer runs with -rss_limit_mb above that (tools/run-fuzzers.sh): an input that makes a reader
// hold more than its limit — a header that lies, a decompression bomb — is a finding. So is any
// crash, leak or sanitizer report, and any exception but those of bad input (the CLI's exit code
// 1): a reader that threw InvalidParameter would make bad input look like a bad option (exit 2).
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

constexpr std::size_t kReadLimit = std::size_t(256) << 20;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto& r = reader();
  meniscus::io::Source source;
  source.bytes = meniscus::io::ByteView(data, size);
  source.path = std::string("fuzz-input") + (r.extensions.empty() ? "" : r.extensions.front());
  source.limit = {kReadLimit, "the fuzzer's 256 MB"};
  meniscus::ReadOptions options;
  meniscus::ReadReport report;
  try {
    const meniscus::ParticleSet particles = r.read(source, options, &report);
    particles.validate();
  } catch (const meniscus::FormatError&) {
  } catch (const meniscus::ResourceError&) {
  } catch (const meniscus::InputError&) {
  }
  return 0;
}
