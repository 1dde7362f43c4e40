// meniscus — the exceptions the library throws. Library code never exits the process.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

namespace meniscus {

/// `text` safe to print on a terminal: control characters (but newline and tab), DEL, C1 controls
/// and bytes that are not UTF-8 written as \xNN, so that bytes quoted out of a file cannot clear
/// the screen or retitle the window. Everything else, UTF-8 included, is kept.
std::string printable(std::string_view text);

/// A parameter is out of range or inconsistent with another (names the parameter and value).
/// Front ends report it as a bad option or usage (the CLI's exit code 2).
class InvalidParameter : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
  /// A parameter's value that is refused: what() is the setting as the front end spells it
  /// (messages.hpp: "--steps-a 20001", "steps_a=20001") followed by ": " and `expectation`.
  InvalidParameter(std::string key, std::string value, std::string expectation);
  /// The parameter's key ("steps_a"), its value as written and what was expected; empty for a
  /// message that is not about one value.
  const std::string& key() const noexcept { return key_; }
  const std::string& value() const noexcept { return value_; }
  const std::string& expectation() const noexcept { return expectation_; }

 private:
  std::string key_, value_, expectation_;
};

/// The input data cannot be surfaced as it is (too few particles, all at one point, coordinates
/// beyond what single precision resolves), though it was read: bad input, not a bad option.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A file could not be read or parsed. `what()` names the file, the byte offset or line
/// where the problem was found, and what was expected there (printable(): bytes quoted out of
/// the file are escaped).
class FormatError : public std::runtime_error {
 public:
  /// `location` is e.g. "byte 1024" or "line 7"; may be empty for whole-file errors.
  FormatError(const std::string& file, const std::string& location, const std::string& message)
      : std::runtime_error(printable(file) + (location.empty() ? "" : ": " + printable(location)) + ": " +
                           printable(message)),
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
