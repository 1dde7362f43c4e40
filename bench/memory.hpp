// meniscus bench — per-phase peak memory: reset the kernel's RSS high-water mark, run, read it.
#pragma once

#include <malloc.h>

#include <cstddef>
#include <fstream>
#include <string>

namespace meniscus::bench {

// Reads a "Name:   1234 kB" line of /proc/self/status, in bytes (0 when unavailable).
inline std::size_t proc_status_bytes(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  const std::string prefix = std::string(key) + ":";
  while (std::getline(f, line))
    if (line.compare(0, prefix.size(), prefix) == 0) return std::size_t(std::stoull(line.substr(prefix.size()))) * 1024;
  return 0;
}

/// Starts a measurement: returns the current RSS after handing freed heap back to the OS
/// (malloc_trim) and resetting VmHWM to it (writing 5 to clear_refs, Linux ≥ 4.0). Without the
/// trim, memory freed by an earlier tool would be reused and under-count the next one.
/// Returns false in *reset_ok when the kernel refused the reset (the peak is then process-wide).
inline std::size_t begin_peak_measurement(bool* reset_ok = nullptr) {
  malloc_trim(0);
  std::ofstream f("/proc/self/clear_refs");
  f << "5";
  f.flush();
  if (reset_ok) *reset_ok = bool(f);
  return proc_status_bytes("VmRSS");
}

/// Peak RSS since begin_peak_measurement, minus the RSS it returned: the phase's own peak.
inline std::size_t peak_delta_bytes(std::size_t base) {
  const std::size_t hwm = proc_status_bytes("VmHWM");
  return hwm > base ? hwm - base : 0;
}

}  // namespace meniscus::bench
