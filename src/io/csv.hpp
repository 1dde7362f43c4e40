// meniscus io — delimited text particles (".csv", ".txt": RFC 4180-style CSV and whitespace columns such as SPHysics IPART).
#pragma once

#include "io/format_registry.hpp"

namespace meniscus::io {

/// One particle per line, fields separated by commas, semicolons or whitespace (chosen from the
/// first line). Column names come from ReadOptions::columns when given (a non-numeric first line
/// is then skipped as a header), otherwise from a header line (optionally starting with '#').
/// x, y, z (any case; ParaView's "Points:0/1/2" too) are required; vx vy vz / u v w / velocity_x …
/// group into "velocity", nx ny nz into "normal", <n>_x/_y/_z and <n>:0 … <n>:k into "<n>"; other
/// columns become 1-component attributes (integer when every value is written as an integer).
/// Lines starting with '#' after the header and blank lines are skipped. Throws FormatError
/// naming the line and column of a bad token, a missing x/y/z column or a short row.
ParticleSet read_csv_particles(const Source& source, const ReadOptions& options, ReadReport* report);

}  // namespace meniscus::io
