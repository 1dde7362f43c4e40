// meniscus — one frame over the ranks of an MPI job (apps/meniscus/mpi_surface.hpp).
#include "mpi_surface.hpp"

#include <fmt/format.h>
#include <mpi.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <climits>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/clock.hpp"
#include "io/atomic_file.hpp"
#include "io/format_registry.hpp"
#include "io/ply.hpp"
#include "io/vtu.hpp"
#include "meniscus/distributed.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/memory.hpp"
#include "meniscus/reconstruct.hpp"
#include "pipeline/stage_plan.hpp"

namespace meniscus::cli {
namespace {

// --- A byte buffer for particle sets and meshes (names, counts, arrays; this machine's byte order,
// as the ranks of one job share it).

struct Writer {
  std::vector<char> bytes;
  template <class T>
  void put(const T& v) {
    const char* p = reinterpret_cast<const char*>(&v);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  template <class T>
  void put_array(const std::vector<T>& v) {
    put(uint64_t(v.size()));
    const char* p = reinterpret_cast<const char*>(v.data());
    bytes.insert(bytes.end(), p, p + v.size() * sizeof(T));
  }
  void put_string(const std::string& s) { put_array(std::vector<char>(s.begin(), s.end())); }
};

struct Reader {
  const std::vector<char>& bytes;
  std::size_t at = 0;
  void need(std::size_t n) {
    if (bytes.size() - at < n) throw std::runtime_error(fmt::format("MPI message: {} bytes short at byte {}", n, at));
  }
  template <class T>
  T get() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, bytes.data() + at, sizeof(T));
    at += sizeof(T);
    return v;
  }
  template <class T>
  std::vector<T> get_array() {
    const uint64_t n = get<uint64_t>();
    if (n > (bytes.size() - at) / sizeof(T)) throw std::runtime_error(fmt::format("MPI message: an array of {} is cut short", n));
    std::vector<T> v(n);
    if (n > 0) std::memcpy(v.data(), bytes.data() + at, n * sizeof(T));  // (an empty vector's data() may be null)
    at += n * sizeof(T);
    return v;
  }
  std::string get_string() {
    const std::vector<char> c = get_array<char>();
    return {c.begin(), c.end()};
  }
};

void put_attributes(Writer& w, const std::vector<Attribute>& attributes) {
  w.put(uint64_t(attributes.size()));
  for (const Attribute& a : attributes) {
    w.put_string(a.name);
    w.put(int32_t(a.components));
    w.put(uint8_t(a.integer));
    w.put_array(a.values);
  }
}

std::vector<Attribute> get_attributes(Reader& r) {
  std::vector<Attribute> out(r.get<uint64_t>());
  for (Attribute& a : out) {
    a.name = r.get_string();
    a.components = r.get<int32_t>();
    a.integer = r.get<uint8_t>() != 0;
    a.values = r.get_array<float>();
  }
  return out;
}

std::vector<char> pack(const ParticleSet& p) {
  Writer w;
  w.put_array(p.positions);
  put_attributes(w, p.attributes);
  return std::move(w.bytes);
}

ParticleSet unpack_particles(const std::vector<char>& bytes) {
  Reader r{bytes};
  ParticleSet p;
  p.positions = r.get_array<Vec3f>();
  p.attributes = get_attributes(r);
  return p;
}


// --- Messages of any size: a count, then chunks of at most 1 GiB (MPI counts are int).

constexpr std::size_t kChunk = std::size_t(1) << 30;

void send_bytes(const std::vector<char>& bytes, int to, int tag) {
  const uint64_t n = bytes.size();
  MPI_Send(&n, 1, MPI_UINT64_T, to, tag, MPI_COMM_WORLD);
  for (std::size_t at = 0; at < n; at += kChunk)
    MPI_Send(bytes.data() + at, int(std::min(kChunk, n - at)), MPI_BYTE, to, tag, MPI_COMM_WORLD);
}

std::vector<char> receive_bytes(int from, int tag) {
  uint64_t n = 0;
  MPI_Recv(&n, 1, MPI_UINT64_T, from, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  std::vector<char> bytes(n);
  for (std::size_t at = 0; at < n; at += kChunk)
    MPI_Recv(bytes.data() + at, int(std::min(kChunk, n - at)), MPI_BYTE, from, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return bytes;
}

void send_raw(const void* data, std::size_t bytes, int to, int tag) {
  const char* p = static_cast<const char*>(data);
  for (std::size_t at = 0; at < bytes; at += kChunk)
    MPI_Send(p + at, int(std::min(kChunk, bytes - at)), MPI_BYTE, to, tag, MPI_COMM_WORLD);
}

void receive_raw(void* data, std::size_t bytes, int from, int tag) {
  char* p = static_cast<char*>(data);
  for (std::size_t at = 0; at < bytes; at += kChunk)
    MPI_Recv(p + at, int(std::min(kChunk, bytes - at)), MPI_BYTE, from, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
}

enum Tag : int { kParticles = 1, kPiece = 2 };

/// A piece travels to rank 0 in two messages, so that rank 0 holds only the positions of all the
/// pieces at once (PieceWelder): first its counts, attribute names and positions, then, when rank 0
/// asks for it by receiving, its attributes and triangles. Normals do not travel: the welded mesh's
/// are computed again.
struct PieceHead {
  uint64_t vertices = 0, triangles = 0;
  bool normals = false;
  std::vector<Attribute> attributes;  // names and sizes; the values come with the second message
};

void send_piece_vertices(const TriangleMesh& m, int to, int tag) {
  Writer w;
  w.put(uint64_t(m.vertices.size()));
  w.put(uint64_t(m.triangles.size()));
  w.put(uint8_t(m.normals.size() == m.vertices.size()));
  w.put(uint64_t(m.attributes.size()));
  for (const Attribute& a : m.attributes) {
    w.put_string(a.name);
    w.put(int32_t(a.components));
    w.put(uint8_t(a.integer));
    w.put(uint64_t(a.values.size()));
  }
  send_bytes(w.bytes, to, tag);
  send_raw(m.vertices.data(), m.vertices.size() * sizeof(Vec3f), to, tag);
}

void send_piece_rest(const TriangleMesh& m, int to, int tag) {
  for (const Attribute& a : m.attributes) send_raw(a.values.data(), a.values.size() * sizeof(float), to, tag);
  send_raw(m.triangles.data(), m.triangles.size() * sizeof(Triangle), to, tag);
}

PieceHead receive_piece_vertices(int from, int tag, std::vector<Vec3f>& positions) {
  const std::vector<char> head = receive_bytes(from, tag);
  Reader r{head};
  PieceHead h;
  h.vertices = r.get<uint64_t>();
  h.triangles = r.get<uint64_t>();
  h.normals = r.get<uint8_t>() != 0;
  h.attributes.resize(r.get<uint64_t>());
  for (Attribute& a : h.attributes) {
    a.name = r.get_string();
    a.components = r.get<int32_t>();
    a.integer = r.get<uint8_t>() != 0;
    a.values.resize(r.get<uint64_t>());  // sized here, filled by receive_piece_rest
  }
  positions.resize(h.vertices);
  receive_raw(positions.data(), positions.size() * sizeof(Vec3f), from, tag);
  return h;
}

/// Fills the head's attribute values and returns the triangles.
std::vector<Triangle> receive_piece_rest(PieceHead& h, int from, int tag) {
  for (Attribute& a : h.attributes) receive_raw(a.values.data(), a.values.size() * sizeof(float), from, tag);
  std::vector<Triangle> triangles(h.triangles);
  receive_raw(triangles.data(), triangles.size() * sizeof(Triangle), from, tag);
  return triangles;
}

/// The streamed gather (StreamPart): each rank sends its part in two messages, its written
/// vertices first and, once rank 0 has written every rank's vertices, its triangles.
void send_part(const StreamPart& part, int to, int tag) {
  send_piece_vertices(part.written, to, tag);
  send_raw(part.shared_up.data(), part.shared_up.size(), to, tag);
  for (const Attribute& a : part.written.attributes) send_raw(a.values.data(), a.values.size() * sizeof(float), to, tag);
  send_raw(part.written.normals.data(), part.written.normals.size() * sizeof(Vec3f), to, tag);
  const uint64_t counts[2] = {part.triangles.size(), part.foreign.size()};
  send_raw(counts, sizeof counts, to, tag);
  send_raw(part.triangles.data(), part.triangles.size() * sizeof(Triangle), to, tag);
  send_raw(part.foreign.data(), part.foreign.size() * sizeof(Vec3f), to, tag);
}

/// Rank 0: writes the PLY from its own part and the other ranks' as they come, the header from
/// `counts` (written vertices and triangles of each rank). Returns the vertex count.
std::size_t write_streamed(const std::string& path, StreamPart own, int ranks, const std::vector<uint64_t>& counts) {
  std::size_t vertices = 0, triangles = 0;
  for (int r = 0; r < ranks; ++r) vertices += counts[2 * std::size_t(r)], triangles += counts[2 * std::size_t(r) + 1];

  // The vertices, rank by rank (rank 0's own first); the layout is the first non-empty part's.
  StreamIndex index;
  std::optional<io::PlyMeshWriter> writer;
  auto write_vertices = [&](const StreamPart& part) {
    index.add_written(part.written.vertices, part.shared_up);
    if (part.written.vertices.empty()) return;
    if (!writer) writer.emplace(path, vertices, triangles, part.written);
    writer->add_vertices(part.written);
  };
  write_vertices(own);
  own.written = {}, own.shared_up = {};
  for (int r = 1; r < ranks; ++r) {
    StreamPart part;
    const PieceHead head = receive_piece_vertices(r, kPiece, part.written.vertices);
    part.shared_up.resize(part.written.vertices.size());
    receive_raw(part.shared_up.data(), part.shared_up.size(), r, kPiece);
    part.written.attributes = head.attributes;
    for (Attribute& a : part.written.attributes) receive_raw(a.values.data(), a.values.size() * sizeof(float), r, kPiece);
    if (head.normals) {
      part.written.normals.resize(part.written.vertices.size());
      receive_raw(part.written.normals.data(), part.written.normals.size() * sizeof(Vec3f), r, kPiece);
    }
    write_vertices(part);
  }
  if (!writer) {  // no rank has a vertex: an empty mesh
    writer.emplace(path, 0, 0, TriangleMesh{});
  }

  // The triangles, rank by rank.
  index.resolve(0, own.triangles, own.foreign);
  writer->add_triangles(own.triangles.data(), own.triangles.size());
  own = {};
  for (int r = 1; r < ranks; ++r) {
    uint64_t n[2] = {0, 0};
    receive_raw(n, sizeof n, r, kPiece);
    std::vector<Triangle> t(n[0]);
    std::vector<Vec3f> foreign(n[1]);
    receive_raw(t.data(), t.size() * sizeof(Triangle), r, kPiece);
    receive_raw(foreign.data(), foreign.size() * sizeof(Vec3f), r, kPiece);
    index.resolve(std::size_t(r), t, foreign);
    writer->add_triangles(t.data(), t.size());
  }
  writer->commit();
  return vertices;
}

/// MPI_Allreduce as the frame-wide estimates' reductions (distributed.hpp).
Reduce mpi_reduce() {
  Reduce r;
  r.min = [](std::vector<float>& v) {
    MPI_Allreduce(MPI_IN_PLACE, v.data(), int(v.size()), MPI_FLOAT, MPI_MIN, MPI_COMM_WORLD);
  };
  r.sum = [](std::vector<uint64_t>& v) {
    MPI_Allreduce(MPI_IN_PLACE, v.data(), int(v.size()), MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  };
  return r;
}

/// Every rank sends each rank the particles of its part within that rank's slab and halo; a
/// rank's slab is what it receives, in rank order (the parts are consecutive ranges of the frame,
/// so this is slab_particles() of the whole frame). Pairs of ranks exchange in K − 1 rounds.
/// `input` names the frame in errors.
ParticleSet exchange_slabs(ParticleSet part, const Decomposition& d, int rank, int ranks, const std::string& input) {
  std::vector<ParticleSet> received(static_cast<std::size_t>(ranks));
  received[std::size_t(rank)] = slab_particles(part, d, rank);
  for (int round = 1; round < ranks; ++round) {
    const int to = (rank + round) % ranks, from = (rank - round + ranks) % ranks;
    const std::vector<char> out = pack(slab_particles(part, d, to));
    uint64_t sizes[2] = {out.size(), 0};
    MPI_Sendrecv(&sizes[0], 1, MPI_UINT64_T, to, kParticles, &sizes[1], 1, MPI_UINT64_T, from, kParticles,
                 MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    std::vector<char> in(sizes[1]);
    for (std::size_t at = 0; at < std::max(out.size(), in.size()); at += kChunk) {
      const std::size_t n_out = at < out.size() ? std::min(kChunk, out.size() - at) : 0;
      const std::size_t n_in = at < in.size() ? std::min(kChunk, in.size() - at) : 0;
      MPI_Sendrecv(out.data() + std::min(at, out.size()), int(n_out), MPI_BYTE, to, kParticles,
                   in.data() + std::min(at, in.size()), int(n_in), MPI_BYTE, from, kParticles, MPI_COMM_WORLD,
                   MPI_STATUS_IGNORE);
    }
    received[std::size_t(from)] = unpack_particles(in);
  }
  part = {};
  ParticleSet slab;
  std::size_t n = 0;
  for (const ParticleSet& p : received) n += p.size();
  slab.positions.reserve(n);
  for (const Attribute& a : received[std::size_t(rank)].attributes) slab.attributes.push_back({a.name, a.components, a.integer, {}});
  for (ParticleSet& p : received) {
    slab.positions.insert(slab.positions.end(), p.positions.begin(), p.positions.end());
    if (p.size() > 0) {
      if (p.attributes.size() != slab.attributes.size())
        throw FormatError(input, "", "the ranks' parts of the frame do not have the same attributes");
      for (std::size_t a = 0; a < p.attributes.size(); ++a)
        slab.attributes[a].values.insert(slab.attributes[a].values.end(), p.attributes[a].values.begin(),
                                         p.attributes[a].values.end());
    }
    p = {};
  }
  return slab;
}

/// Whether every rank succeeded; a rank that failed prints its message first.
bool all_ok(const std::optional<std::string>& error, int rank) {
  if (error) fmt::print(stderr, "meniscus: rank {}: error: {}\n", rank, *error);
  int ok = error ? 0 : 1, all = 0;
  MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  return all == 1;
}

template <class F>
std::optional<std::string> attempt(F&& f) {
  try {
    f();
    return std::nullopt;
  } catch (const std::exception& e) {
    return std::string(e.what());
  }
}

/// What each rank reports to rank 0 for the stats.
struct RankReport {
  double particles = 0, owned_vertices = 0, owned_triangles = 0, surface_seconds = 0, peak_bytes = 0;
  double removed_voids = 0, removed_blobs = 0, dropped_triangles = 0;  // in its slab with the halo
};
constexpr int kReportFields = 8;
static_assert(sizeof(RankReport) == kReportFields * sizeof(double));

}  // namespace

bool mpi_built() { return true; }

MpiSession::MpiSession(int* argc, char*** argv) {
  if (launched_ranks() == 0) return;
  int provided = 0;
  MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  active_ = true;
}

MpiSession::~MpiSession() {
  if (active_) MPI_Finalize();
}

namespace {

/// One frame surfaced by the ranks of a job, in phases (the stats name their times: read or
/// read_parts, scatter or exchange, surface, gather_weld, gather_write or write_pieces, write). Every rank runs every phase; a phase
/// returns false on every rank when one failed (each failing rank has printed why).
class RankRun {
 public:
  RankRun(const MpiSession& session, const MpiJob& job)
      : job_(job), rank_(session.rank()), ranks_(session.size()), reduce_(mpi_reduce()) {}

  /// The frame: a file of fixed-size records (binary PLY, raw .xyz) is read in parts, one per
  /// rank, and the frame-wide estimates (spacing, rest density, velocity reference) are reductions
  /// over the parts; any other file is read by rank 0, which makes them on the whole frame.
  bool read_frame() {
    uint64_t records = 0;
    if (rank_ == 0) records = particle_records(job_.input);
    MPI_Bcast(&records, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    in_parts_ = records >= uint64_t(ranks_) && ranks_ > 1;
    std::optional<std::string> error;
    Params given = job_.params;
    if (in_parts_) {
      const uint64_t begin = records * uint64_t(rank_) / uint64_t(ranks_);
      const uint64_t end = records * uint64_t(rank_ + 1) / uint64_t(ranks_);
      ReadReport report;
      error = attempt([&] {
        all_ = read_particle_range(job_.input, begin, end - begin, job_.read, &report);
        keep_particles_in_box(all_, job_.params.particle_box);
      });
      if (!all_ok(error, rank_)) return false;
      // Where this part starts once particles with NaN/Inf coordinates are dropped.
      uint64_t kept = all_.size(), before = 0, sum = 0;
      MPI_Exscan(&kept, &before, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
      MPI_Allreduce(&kept, &sum, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
      const std::size_t first = rank_ == 0 ? 0 : std::size_t(before);
      total_particles_ = std::size_t(sum);
      if (total_particles_ == 0)
        error = fmt::format(
            "{}: no particles once those with NaN/Inf coordinates or outside --particle-box are dropped", job_.input);
      if (!all_ok(rank_ == 0 ? error : std::nullopt, rank_)) return false;
      error =
          attempt([&] { given = resolve_frame_estimates_parts(all_, first, total_particles_, job_.params, reduce_); });
    } else if (rank_ == 0) {
      error = attempt([&] {
        all_ = read_particles(job_.input, job_.read);
        keep_particles_in_box(all_, job_.params.particle_box);
        if (all_.size() == 0) throw InvalidParameter("particle_box: all the frame's particles are outside the box");
        given = resolve_frame_estimates(all_, job_.params);
        total_particles_ = all_.size();
      });
    }
    if (!all_ok(error, rank_)) return false;
    stages_.emplace_back(in_parts_ ? "read_parts" : "read", seconds_since(t0_));
    double estimates[3] = {given.spacing, given.rest_density, given.velocity_reference};
    MPI_Bcast(estimates, 3, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    given_ = job_.params;
    given_.spacing = estimates[0], given_.rest_density = estimates[1], given_.velocity_reference = estimates[2];
    return true;
  }

  /// The slabs: every rank computes the same cuts (from the parts), or rank 0 sends them.
  bool cut_slabs() {
    phase_start_ = std::chrono::steady_clock::now();
    std::optional<std::string> error;
    if (in_parts_) {
      error = attempt([&] {
        d_ = decompose_parts(all_, total_particles_, resolve_params(ParticleSet{{Vec3f{}}, {}}, given_), ranks_,
                             reduce_);
      });
      return all_ok(error, rank_);
    }
    std::vector<double> cuts_message(std::size_t(ranks_) + 1);  // axis, halo, cuts
    if (rank_ == 0)
      error = attempt([&] {
        d_ = decompose(all_, resolve_params(all_, given_), ranks_);
        cuts_message[0] = d_.axis, cuts_message[1] = d_.halo;
        std::copy(d_.cuts.begin(), d_.cuts.end(), cuts_message.begin() + 2);
      });
    if (!all_ok(error, rank_)) return false;
    MPI_Bcast(cuts_message.data(), ranks_ + 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    d_.ranks = ranks_, d_.axis = int(cuts_message[0]), d_.halo = cuts_message[1];
    d_.cuts.assign(cuts_message.begin() + 2, cuts_message.end());
    return true;
  }

  /// Each rank its slab with its halo, attributes travelling with the particles: from rank 0, or
  /// from every rank's part (concatenated in rank order: the frame's order, as slab_particles keeps).
  bool send_slabs() {
    std::optional<std::string> error;
    if (in_parts_) {
      error = attempt([&] { slab_ = exchange_slabs(std::move(all_), d_, rank_, ranks_, job_.input); });
      all_ = {};
    } else if (rank_ == 0) {
      for (int r = 1; r < ranks_; ++r) send_bytes(pack(slab_particles(all_, d_, r)), r, kParticles);
      slab_ = slab_particles(all_, d_, 0);
      all_ = {};
    } else {
      error = attempt([&] { slab_ = unpack_particles(receive_bytes(0, kParticles)); });
    }
    if (!all_ok(error, rank_)) return false;
    MPI_Bcast(&total_particles_, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    stages_.emplace_back(in_parts_ ? "exchange" : "scatter", seconds_since(phase_start_));
    return true;
  }

  /// Every rank surfaces its slab and keeps the triangles it owns.
  bool surface_slab() {
    const auto t = std::chrono::steady_clock::now();
    // A PLY output is written as the pieces come (each vertex once; rank 0 holds one piece at a
    // time); other formats are welded whole on rank 0 first.
    std::string extension = std::filesystem::path(job_.output).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    streamed_ = !job_.pieces && extension == ".ply";
    report_.particles = double(slab_.size());
    const std::optional<std::string> error = attempt([&] {
      if (slab_.size() == 0) return;  // a slab without particles owns no triangle
      result_ = reconstruct(slab_, given_);
      keep_owned(result_.mesh, d_, rank_, streamed_ ? &seams_ : nullptr);
      piece_ = std::move(result_.mesh);
      result_.mesh = {};
    });
    slab_ = {};
    report_.surface_seconds = seconds_since(t);
    report_.owned_vertices = double(piece_.vertices.size());
    report_.owned_triangles = double(piece_.triangles.size());
    report_.removed_voids = double(result_.stats.removed_voids);
    report_.removed_blobs = double(result_.stats.removed_blobs);
    report_.dropped_triangles = double(result_.stats.dropped_triangles);
    return all_ok(error, rank_);
  }

  /// The pieces to rank 0. --pieces: every rank writes its own; rank 0 the index. A PLY: streamed
  /// to the file. Otherwise rank 0 welds the pieces as they come (PieceWelder): every piece's
  /// positions first, then each piece's attributes and triangles, one piece at a time. Then the
  /// ranks' reports to rank 0.
  bool gather_pieces() {
    const auto t = std::chrono::steady_clock::now();
    std::optional<std::string> error;
    if (job_.pieces) {
      error = attempt([&] { io::write_vtp_mesh(piece_path(job_.output, rank_), piece_); });
      if (!all_ok(error, rank_)) return false;
      if (rank_ == 0) {
        std::vector<std::string> names;
        for (int r = 0; r < ranks_; ++r)
          names.push_back(std::filesystem::path(piece_path(job_.output, r)).filename().string());
        error = attempt([&] { io::write_pvtp_index(job_.output, names, piece_); });
      }
      if (!all_ok(error, rank_)) return false;
      piece_ = {};
    } else if (streamed_) {
      StreamPart part = stream_part(std::move(piece_), seams_, rank_);
      piece_ = {}, seams_ = {};
      const uint64_t mine[2] = {part.written.vertices.size(), part.triangles.size()};
      std::vector<uint64_t> counts(2 * std::size_t(ranks_));
      MPI_Gather(mine, 2, MPI_UINT64_T, counts.data(), 2, MPI_UINT64_T, 0, MPI_COMM_WORLD);
      if (rank_ == 0) {
        error = attempt([&] { streamed_vertices_ = write_streamed(job_.output, std::move(part), ranks_, counts); });
      } else {
        send_part(part, 0, kPiece);
      }
    } else if (rank_ == 0) {
      error = attempt([&] { mesh_ = weld_pieces(); });
    } else {
      send_piece_vertices(piece_, 0, kPiece);
      send_piece_rest(piece_, 0, kPiece);
      piece_ = {};
    }
    if (error) {
      // Only rank 0 can fail here, in the weld (pieces that do not fit together) or the streamed
      // write, with ranks still waiting to send: nothing is written, every rank stops.
      fmt::print(stderr, "meniscus: rank 0: error: {}\n", *error);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    stages_.emplace_back(job_.pieces ? "write_pieces" : streamed_ ? "gather_write" : "gather_weld", seconds_since(t));
    report_.peak_bytes = double(peak_resident_bytes());
    reports_.resize(static_cast<std::size_t>(ranks_));
    MPI_Gather(&report_, kReportFields, MPI_DOUBLE, reports_.data(), kReportFields, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    double slowest = 0;
    for (const RankReport& r : reports_) slowest = std::max(slowest, r.surface_seconds);
    stages_.insert(stages_.end() - 1, {"surface", slowest});
    return true;
  }

  /// Rank 0 writes the welded mesh, the summary and the stats; every rank returns its exit code.
  int write_outputs() {
    int code = 0;
    if (rank_ == 0) {
      const std::optional<std::string> error = attempt([&] { write_and_report(); });
      if (error) {
        fmt::print(stderr, "meniscus: error: {}\n", *error);
        code = 1;
      }
    }
    MPI_Bcast(&code, 1, MPI_INT, 0, MPI_COMM_WORLD);
    return code;
  }

 private:
  TriangleMesh weld_pieces() {
    PieceWelder welder(static_cast<std::size_t>(ranks_));
    std::vector<PieceHead> heads(static_cast<std::size_t>(ranks_));
    bool normals = piece_.normals.size() == piece_.vertices.size();
    std::size_t triangles = piece_.triangles.size();
    std::vector<Vec3f>().swap(piece_.normals);
    welder.add_vertices(0, std::move(piece_.vertices));
    for (int r = 1; r < ranks_; ++r) {
      std::vector<Vec3f> positions;
      heads[std::size_t(r)] = receive_piece_vertices(r, kPiece, positions);
      normals = normals && heads[std::size_t(r)].normals;
      triangles += heads[std::size_t(r)].triangles;
      welder.add_vertices(std::size_t(r), std::move(positions));
    }
    welder.weld_vertices();
    welder.reserve_triangles(triangles);
    welder.add_attributes(0, piece_.attributes);
    welder.add_triangles(0, piece_.triangles);
    piece_ = {};
    for (int r = 1; r < ranks_; ++r) {
      PieceHead& h = heads[std::size_t(r)];
      const std::vector<Triangle> t = receive_piece_rest(h, r, kPiece);
      welder.add_attributes(std::size_t(r), h.attributes);
      h = {};
      welder.add_triangles(std::size_t(r), t);
    }
    return welder.finish(normals);
  }

  void write_and_report() {
    const auto t4 = std::chrono::steady_clock::now();
    const Params p = result_.params.spacing > 0 ? result_.params : resolve_params(ParticleSet{{Vec3f{}}, {}}, given_);
    // The counts: the welded mesh's, or with --pieces the pieces' sums (seam vertices in each piece).
    std::size_t vertices = 0, triangles = 0;
    for (const RankReport& r : reports_)
      vertices += std::size_t(r.owned_vertices), triangles += std::size_t(r.owned_triangles);
    if (streamed_) {
      vertices = streamed_vertices_;
      reports_[0].peak_bytes = double(peak_resident_bytes());  // rank 0's peak with the gather and the write
    } else if (!job_.pieces) {
      vertices = mesh_.vertices.size();
      write_mesh(job_.output, mesh_);
      mesh_ = {};
      stages_.emplace_back("write", seconds_since(t4));
      reports_[0].peak_bytes = double(peak_resident_bytes());  // rank 0's peak with the weld and the write
    }
    double total = 0, peak = 0;
    for (const auto& [name, s] : stages_) total += s;
    for (const RankReport& r : reports_) peak = std::max(peak, r.peak_bytes);
    if (!job_.quiet) {
      fmt::print(stderr,
                 "{} particles → {} vertices, {} triangles in {:.3f}s on {} ranks (slabs along {}, halo {:.4g} = "
                 "{:.1f} spacings), peak memory per rank {:.0f} MB at most\n",
                 total_particles_, vertices, triangles, total, ranks_, "xyz"[d_.axis], d_.halo, d_.halo / p.spacing,
                 peak / 1e6);
      std::string line;
      for (const auto& [name, s] : stages_) line += fmt::format("{}{} {:.3f}s", line.empty() ? "" : ", ", name, s);
      fmt::print(stderr, "  {}\n", line);
      for (int r = 0; r < ranks_; ++r) {
        const RankReport& q = reports_[std::size_t(r)];
        fmt::print(
            stderr,
            "  rank {}: {:.0f} particles with its halo, owns {:.0f} triangles, surfaced in {:.3f}s, peak {:.0f} MB\n",
            r, q.particles, q.owned_triangles, q.surface_seconds, q.peak_bytes / 1e6);
      }
      fmt::print(stderr, "wrote {}{}{}\n", job_.output,
                 job_.pieces ? fmt::format(" and its {} pieces {} … (vertices counted per piece: the seams twice)",
                                           ranks_, piece_path(job_.output, 0))
                             : "",
                 job_.stats.empty() ? "" : ", " + job_.stats);
    }
    if (!job_.stats.empty()) {
      Result summary;
      summary.params = p;
      summary.stats = result_.stats;
      summary.stats.particles = total_particles_;
      summary.stats.vertices = vertices;
      summary.stats.triangles = triangles;
      summary.stats.peak_memory_bytes = std::size_t(peak);
      summary.stats.stages.clear();
      for (const auto& [name, s] : stages_) summary.stats.stages.push_back({name, s});
      nlohmann::ordered_json j = nlohmann::ordered_json::parse(stats_to_json(summary));
      // What each rank removed is counted in its slab with the halo, where the halo's components
      // are counted by two ranks: per rank only (the mesh does not depend on K; these counts do).
      for (const char* key : {"removed_voids", "removed_blobs", "dropped_triangles"}) j[key] = nullptr;
      j["ranks"] = ranks_;
      j["decomposition"] = {{"axis", std::string(1, "xyz"[d_.axis])},
                            {"cuts", d_.cuts},
                            {"halo", d_.halo},
                            {"halo_spacings", d_.halo / p.spacing}};
      nlohmann::ordered_json per_rank = nlohmann::ordered_json::array();
      for (int r = 0; r < ranks_; ++r) {
        const RankReport& q = reports_[std::size_t(r)];
        per_rank.push_back({{"rank", r},
                            {"particles_with_halo", q.particles},
                            {"owned_vertices", q.owned_vertices},
                            {"owned_triangles", q.owned_triangles},
                            {"surface_seconds", q.surface_seconds},
                            {"peak_memory_bytes", q.peak_bytes},
                            {"removed_voids", q.removed_voids},
                            {"removed_blobs", q.removed_blobs},
                            {"dropped_triangles", q.dropped_triangles}});
      }
      j["per_rank"] = per_rank;
      const std::string text = j.dump(2) + "\n";
      io::AtomicFile file(job_.stats);
      file.write(text.data(), text.size());
      file.commit();
    }
  }

  const MpiJob& job_;
  const int rank_, ranks_;
  const Reduce reduce_;
  const std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point phase_start_;
  std::vector<std::pair<std::string, double>> stages_;  // rank 0's view of the job
  bool in_parts_ = false, streamed_ = false;
  ParticleSet all_;  // rank 0's whole frame, or each rank's part
  Params given_;     // the job's parameters with the frame-wide estimates
  std::size_t total_particles_ = 0, streamed_vertices_ = 0;
  Decomposition d_;
  ParticleSet slab_;
  Seams seams_;
  TriangleMesh piece_, mesh_;
  Result result_;
  RankReport report_;
  std::vector<RankReport> reports_;
};

}  // namespace

int run_surface_mpi(const MpiSession& session, const MpiJob& job) {
  RankRun run(session, job);
  if (!run.read_frame() || !run.cut_slabs() || !run.send_slabs() || !run.surface_slab() || !run.gather_pieces()) return 1;
  return run.write_outputs();
}

}  // namespace meniscus::cli
