// meniscus tests — a mesh's bits as one number, and the checksums stored in tests/data: what a
// restructuring of the code must leave unchanged (the meshes, bit for bit).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/params.hpp"

namespace meniscus::test {

/// FNV-1a over every bit of the mesh: vertex positions, triangles, normals, each attribute's name,
/// components and values.
uint64_t mesh_checksum(const TriangleMesh& mesh);

/// The variants of a frame the checksums cover: the defaults, another field method, another
/// extractor, the transfer of every attribute, and the post-processing (strays, clip, decimate).
struct ChecksumVariant {
  std::string name;
  Params params;  ///< before the frame's estimates; spacing 0 → estimated
  bool transfer_all = false;
};
std::vector<ChecksumVariant> checksum_variants();

/// The stored checksum of `key` ("cpu/<frame>/<variant>") in tests/data/checksums.json, or 0 when
/// there is none. With MENISCUS_WRITE_CHECKSUMS=1, record() stores instead (the file is written
/// when the process ends).
uint64_t stored_checksum(const std::string& key);
void record_checksum(const std::string& key, uint64_t value);
bool writing_checksums();

/// Holds the mesh made for `key` to its stored checksum (a failure names the key and the mesh's
/// counts); with MENISCUS_WRITE_CHECKSUMS=1, stores its checksum instead.
void expect_stored_checksum(const std::string& key, const TriangleMesh& mesh);

}  // namespace meniscus::test
