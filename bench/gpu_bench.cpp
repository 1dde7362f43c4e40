// meniscus bench — the CUDA backend's stage times on synthetic jittered blocks (bench/scenes.hpp)
// of 100k, 1M and 10M particles (or --counts). Each stage time is device time measured with CUDA
// events around that stage; "upload" (particles to the device) and "download" (mesh back) are
// listed as stages of their own, so "device total" excludes the transfers and "total" includes
// them. Parameter resolution (the spacing is given, so only the validation) runs on the host.
// --backend cpu prints the same table for the CPU backend (wall-clock stage times). Each scene runs
// twice and the second run is reported (the first pays for the CUDA context and the first-touch of
// device memory). On the device, each stage also gives its kernel launches and its waits (the host
// waiting for the device: copies back, synchronisations), which decide a small frame's time.
#include <fmt/format.h>

#include <cstdint>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "meniscus/backend.hpp"
#include "meniscus/reconstruct.hpp"
#include "scenes.hpp"

int main(int argc, char** argv) {
  using namespace meniscus;
  std::vector<std::size_t> counts{100000, 1000000, 10000000};
  std::string backend = "cuda", scene = "block", field = "distance";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--counts") {
      counts.clear();
      std::stringstream ss(v);
      for (std::string item; std::getline(ss, item, ',');) counts.push_back(std::stoull(item));
    } else if (a == "--backend") {
      backend = v;
    } else if (a == "--scene") {
      scene = v;
    } else if (a == "--field") {
      field = v;
    } else {
      fmt::print(stderr,
                 "usage: meniscus_bench_gpu [--counts 100000,1000000] [--backend cuda|cpu] [--scene block] "
                 "[--field distance|metaball|sph|zhu-bridson|anisotropic]\n");
      return 2;
    }
  }
  std::string why;
  const auto devices = cuda_devices(&why);
  if (backend == "cuda" && devices.empty()) {
    fmt::print(stderr, "meniscus_bench_gpu: no CUDA device ({})\n", why);
    return 1;
  }
  if (!devices.empty())
    fmt::print("device: {} (compute capability {}.{}, {:.1f} GB)\n", devices[0].name, devices[0].major,
               devices[0].minor, double(devices[0].total_memory) / 1e9);

  std::vector<std::string> rows;
  for (std::size_t n : counts) {
    const bench::Scene s = bench::make_scene(scene, n);
    Params p;
    p.spacing = s.spacing;
    p.backend = parse_backend(backend);
    p.field = parse_field(field);
    try {
      reconstruct(s.particles, p);  // warm-up
      const Result r = reconstruct(s.particles, p);
      double transfers = 0;
      uint64_t launches = 0, waits = 0;
      fmt::print("\n{} ({} field) {} particles on {}: {} vertices, {} triangles, {} field blocks\n", scene,
                 field, s.particles.size(), r.stats.backend, r.stats.vertices, r.stats.triangles, r.stats.field_blocks);
      for (const StageTime& t : r.stats.stages) {
        std::string calls;
        for (const DeviceStageCalls& c : r.stats.device_calls)
          if (c.name == t.name) {
            calls = fmt::format("  {:6} launches {:4} waits", c.launches, c.waits);
            launches += c.launches, waits += c.waits;
          }
        fmt::print("  {:<12} {:9.2f} ms{}\n", t.name, t.seconds * 1e3, calls);
        if (t.name == "upload" || t.name == "download") transfers += t.seconds;
      }
      if (!r.stats.device_calls.empty()) fmt::print("  {:<12} {:6} launches, {} waits\n", "device calls", launches, waits);
      const double total = r.stats.total_seconds();
      fmt::print("  {:<12} {:9.2f} ms (without upload/download)\n  {:<12} {:9.2f} ms\n", "device total",
                 (total - transfers) * 1e3, "total", total * 1e3);
      rows.push_back(fmt::format("| {:>10} | {:>10} | {:>10} | {:>12.1f} | {:>10.1f} |", s.particles.size(),
                                 r.stats.vertices, r.stats.backend, (total - transfers) * 1e3, total * 1e3));
    } catch (const std::exception& e) {
      fmt::print(stderr, "{} particles: {}\n", n, e.what());
      rows.push_back(fmt::format("| {:>10} | failed: {} |", n, e.what()));
    }
  }
  fmt::print("\n| particles  | vertices   | backend    | stages (ms)  | total (ms) |\n|---|---|---|---|---|\n");
  for (const std::string& r : rows) fmt::print("{}\n", r);
  return 0;
}
