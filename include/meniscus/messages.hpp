// meniscus — how messages name parameters and sizes, whichever front end prints them.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace meniscus {

/// How messages spell a parameter: as the CLI's option ("--steps-a 20001"), as the Python
/// keyword ("steps_a=20001"), or as the C++ member and config key ("steps_a = 20001", the
/// default). A program sets it once at start-up (the CLI and the Python module do); it is
/// process-wide.
enum class Spelling { cpp, cli, python };
void set_message_spelling(Spelling spelling);
Spelling message_spelling();

/// The parameter `key` (a Params member or a read option: "drop_invalid", "columns",
/// "max_memory_gb") as the front end spells it: "--drop-invalid", "drop_invalid".
std::string spelled(std::string_view key);
/// The parameter with a value: "--steps-a 20001", "steps_a=20001", "steps_a = 20001"; a flag's
/// "true" as the flag alone on the CLI ("--keep-voids") and "keep_voids=True" in Python.
std::string spelled_setting(std::string_view key, std::string_view value);

/// A byte count for people: "812 bytes", "64.0 KB", "3.4 MB", "1.25 GB" (powers of 1000, three
/// significant digits), never "0.0 GB".
std::string human_bytes(double bytes);

/// The candidate nearest to `name` by edit distance when it is near enough to be a typo of it
/// (at most 2 edits, or a third of the name's length), else "": "did you mean …?".
std::string closest_name(std::string_view name, const std::vector<std::string>& candidates);

}  // namespace meniscus
