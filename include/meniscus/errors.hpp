// meniscus — the exceptions the library throws. Library code never exits the process.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace meniscus {

/// A parameter is out of range or inconsistent with another (names the parameter and value).
class InvalidParameter : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// A file could not be read or parsed. `what()` names the file, the byte offset or line
/// where the problem was found, and what was expected there.
class FormatError : public std::runtime_error {
 public:
  /// `location` is e.g. "byte 1024" or "line 7"; may be empty for whole-file errors.
  FormatError(const std::string& file, const std::string& location, const std::string& message)
      : std::runtime_error(file + (location.empty() ? "" : ": " + location) + ": " + message),
        file_(file), location_(location) {}
  const std::string& file() const noexcept { return file_; }
  const std::string& location() const noexcept { return location_; }

 private:
  std::string file_, location_;
};

/// The job would need more memory or a larger index range than the library supports; thrown
/// before anything large is allocated.
class ResourceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A CUDA runtime or library call failed; `what()` names the call's file and line and the
/// CUDA error string. Thrown by the CUDA backend (never exit()); derived from ResourceError
/// because the usual causes are an absent, busy or too small device.
class CudaError : public ResourceError {
 public:
  CudaError(const std::string& file, int line, const std::string& message)
      : ResourceError(file + ":" + std::to_string(line) + ": CUDA error: " + message), file_(file), line_(line) {}
  const std::string& file() const noexcept { return file_; }
  int line() const noexcept { return line_; }

 private:
  std::string file_;
  int line_ = 0;
};

/// An input/output operation failed (cannot open, cannot write, disk full …).
class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace meniscus
