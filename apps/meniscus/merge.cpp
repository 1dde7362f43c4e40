// meniscus CLI — `meniscus merge`: the pieces of an MPI run (a .pvtp, or mesh files) welded into one mesh.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <chrono>
#include <filesystem>

#include "cli.hpp"
#include "common/clock.hpp"
#include "merge.hpp"
#include "meniscus/distributed.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/quality.hpp"

namespace meniscus::cli {

namespace {


/// The piece files an index names (`<Piece Source="…"/>`, relative to the index's folder).
std::vector<std::string> pvtp_pieces(const std::string& index) {
  const std::string text = read_text_file(index);
  std::vector<std::string> out;
  const std::filesystem::path dir = std::filesystem::path(index).parent_path();
  for (std::size_t at = text.find("<Piece"); at != std::string::npos; at = text.find("<Piece", at + 1)) {
    const std::size_t s = text.find("Source=\"", at), e = s == std::string::npos ? s : text.find('"', s + 8);
    const std::size_t end = text.find('>', at);
    if (s == std::string::npos || e == std::string::npos || s > end)
      throw FormatError(index, fmt::format("byte {}", at), "expected <Piece Source=\"…\"/>");
    out.push_back((dir / text.substr(s + 8, e - s - 8)).string());
  }
  if (out.empty()) throw FormatError(index, "", "expected <Piece Source=\"…\"/> entries in the .pvtp index");
  return out;
}

}  // namespace

/// Welds pieces (a .pvtp index, or mesh files) into one mesh by their coincident seam vertices.
/// Each piece is read twice — its positions first, then (after the weld has numbered the
/// vertices) its attributes and triangles — so that the merge holds the pieces' positions and the
/// welded mesh, never every piece whole (PieceWelder).
int run_merge(const MergeArgs& a) {
  check_output_format(a.output);
  std::vector<std::string> files;
  for (const std::string& in : a.inputs) {
    if (in.ends_with(".pvtp")) {
      const std::vector<std::string> listed = pvtp_pieces(in);
      files.insert(files.end(), listed.begin(), listed.end());
    } else {
      files.push_back(in);
    }
  }
  {
    std::vector<RunFile> run = {{a.output, "-o", true}};
    for (const std::string& in : a.inputs) run.push_back({in, "a piece", false});
    for (const std::string& in : files) run.push_back({in, "a piece", false});
    check_run_files(run);
  }
  const auto t0 = std::chrono::steady_clock::now();
  PieceWelder welder(files.size());
  std::vector<std::size_t> counts(files.size());  // each piece's vertices and triangles, to check the second read
  std::size_t vertices = 0, triangles = 0;
  bool normals = true;
  for (std::size_t p = 0; p < files.size(); ++p) {
    TriangleMesh piece = read_mesh(files[p]);
    normals = normals && piece.normals.size() == piece.vertices.size();
    counts[p] = piece.vertices.size() + piece.triangles.size();
    vertices += piece.vertices.size(), triangles += piece.triangles.size();
    welder.add_vertices(p, std::move(piece.vertices));
  }
  welder.weld_vertices();
  welder.reserve_triangles(triangles);
  for (std::size_t p = 0; p < files.size(); ++p) {
    const TriangleMesh piece = read_mesh(files[p]);
    if (piece.vertices.size() + piece.triangles.size() != counts[p])
      throw FormatError(files[p], "", "the piece changed while it was being merged");
    welder.add_attributes(p, piece.attributes);
    welder.add_triangles(p, piece.triangles);
  }
  const TriangleMesh mesh = welder.finish(normals);
  make_parent_dirs(a.output);
  write_mesh(a.output, mesh);
  if (!a.quiet) {
    const TopologyReport t = analyze_topology(mesh);
    fmt::print(stderr, "merged {} pieces: {} vertices ({} on seams welded), {} triangles, {} in {:.3f}s\nwrote {}\n",
               files.size(), mesh.vertices.size(), vertices - mesh.vertices.size(), mesh.triangles.size(),
               t.watertight() ? "watertight" : "NOT watertight", seconds_since(t0), printable(a.output));
  }
  return 0;
}

CLI::App* add_merge_command(CLI::App& app, MergeArgs& merge) {
  CLI::App* cmd = app.add_subcommand("merge", "weld mesh pieces (an MPI run's .pvtp, or mesh files) into one mesh");
  cmd->add_option("pieces", merge.inputs, "a .pvtp index, or the piece files")->required();
  cmd->add_option("-o,--output", merge.output, "mesh file to write")->required();
  cmd->add_flag("-q,--quiet", merge.quiet, "print nothing");
  return cmd;
}

}  // namespace meniscus::cli
