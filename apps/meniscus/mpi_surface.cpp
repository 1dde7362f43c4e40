// meniscus — one frame over the ranks of an MPI job (apps/meniscus/mpi_surface.hpp).
#include "mpi_surface.hpp"

#include <fmt/format.h>
#include <mpi.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <climits>
#include <cmath>
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

enum Tag : int { kParticles = 1, kKeys = 2, kPlaced = 3, kSeams = 4, kVertices = 5, kTriangles = 6 };

// --- The ordered gather's messages (meniscus/distributed.hpp: OrderedGather). Rank 0 numbers the
// vertices from each rank's keys, chunk by chunk, answering each chunk with its vertices' places,
// and tells each rank the places of the seam vertices it refers to; the ranks exchange the terms of
// the seam vertices' normals among themselves; then rank 0 merges their vertices and triangles by
// index.

static_assert(sizeof(VertexOrderKey) == 2 * sizeof(uint64_t), "order keys travel as two 64-bit words");
static_assert(sizeof(NormalTerm) == 40, "normal terms travel as 40 bytes without padding");

std::vector<char> pack(const OrderedGather::KeyChunk& c) {
  Writer w;
  w.put_array(c.keys);
  w.put_array(c.shared_up);
  w.put_array(c.runs);
  return std::move(w.bytes);
}

OrderedGather::KeyChunk unpack_key_chunk(const std::vector<char>& bytes) {
  Reader r{bytes};
  OrderedGather::KeyChunk c;
  c.keys = r.get_array<VertexOrderKey>();
  c.shared_up = r.get_array<uint8_t>();
  c.runs = r.get_array<uint32_t>();
  return c;
}

std::vector<char> pack(const VertexPlaces& p) {
  Writer w;
  w.put_array(p.index);
  w.put_array(p.first_triangle);
  return std::move(w.bytes);
}

VertexPlaces unpack_places(const std::vector<char>& bytes) {
  Reader r{bytes};
  VertexPlaces p;
  p.index = r.get_array<uint32_t>();
  p.first_triangle = r.get_array<uint32_t>();
  return p;
}

std::vector<char> pack(const OrderedGather::VertexChunk& c) {
  Writer w;
  w.put_array(c.index);
  w.put_array(c.vertices.vertices);
  w.put_array(c.vertices.normals);
  put_attributes(w, c.vertices.attributes);
  return std::move(w.bytes);
}

OrderedGather::VertexChunk unpack_vertex_chunk(const std::vector<char>& bytes) {
  Reader r{bytes};
  OrderedGather::VertexChunk c;
  c.index = r.get_array<uint32_t>();
  c.vertices.vertices = r.get_array<Vec3f>();
  c.vertices.normals = r.get_array<Vec3f>();
  c.vertices.attributes = get_attributes(r);
  return c;
}

std::vector<char> pack(const OrderedGather::TriangleChunk& c) {
  Writer w;
  w.put_array(c.index);
  w.put_array(c.triangles);
  return std::move(w.bytes);
}

OrderedGather::TriangleChunk unpack_triangle_chunk(const std::vector<char>& bytes) {
  Reader r{bytes};
  OrderedGather::TriangleChunk c;
  c.index = r.get_array<uint32_t>();
  c.triangles = r.get_array<Triangle>();
  return c;
}

template <class T>
void send_array(const std::vector<T>& values, int to, int tag) {
  Writer w;
  w.put_array(values);
  send_bytes(w.bytes, to, tag);
}

template <class T>
std::vector<T> receive_array(int from, int tag) {
  const std::vector<char> bytes = receive_bytes(from, tag);
  Reader r{bytes};
  return r.get_array<T>();
}

/// Every rank sends each rank the normal terms at that rank's vertices; returns those it receives.
std::vector<NormalTerm> exchange_terms(const std::vector<std::vector<NormalTerm>>& out, int ranks) {
  std::vector<int> send_counts(static_cast<std::size_t>(ranks)), receive_counts(static_cast<std::size_t>(ranks));
  std::vector<int> send_at(static_cast<std::size_t>(ranks)), receive_at(static_cast<std::size_t>(ranks));
  std::vector<NormalTerm> sending;
  for (int r = 0; r < ranks; ++r) {
    const std::vector<NormalTerm>& terms = out[std::size_t(r)];
    if (sending.size() + terms.size() > std::size_t(INT_MAX) / sizeof(NormalTerm))
      throw std::runtime_error("the gather: more seam terms than one MPI message holds");
    send_at[std::size_t(r)] = int(sending.size() * sizeof(NormalTerm));
    send_counts[std::size_t(r)] = int(terms.size() * sizeof(NormalTerm));
    sending.insert(sending.end(), terms.begin(), terms.end());
  }
  MPI_Alltoall(send_counts.data(), 1, MPI_INT, receive_counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  std::size_t total = 0;
  for (int r = 0; r < ranks; ++r) {
    if (total + std::size_t(receive_counts[std::size_t(r)]) > std::size_t(INT_MAX))
      throw std::runtime_error("the gather: more seam terms than one MPI message holds");
    receive_at[std::size_t(r)] = int(total);
    total += std::size_t(receive_counts[std::size_t(r)]);
  }
  std::vector<NormalTerm> received(total / sizeof(NormalTerm));
  MPI_Alltoallv(sending.data(), send_counts.data(), send_at.data(), MPI_BYTE, received.data(), receive_counts.data(),
                receive_at.data(), MPI_BYTE, MPI_COMM_WORLD);
  return received;
}

/// Where rank 0 puts the gathered mesh: a PLY written as the batches come (the header from the
/// numbering's counts), or, for the other formats, the whole mesh, written afterwards.
class GatheredMesh {
 public:
  GatheredMesh(const std::string& path, bool streamed, std::size_t vertices, std::size_t triangles)
      : path_(path), streamed_(streamed), vertices_(vertices), triangles_(triangles) {}
  void add_vertices(const TriangleMesh& batch) {
    if (streamed_) {
      if (!writer_) writer_.emplace(path_, vertices_, triangles_, batch);
      writer_->add_vertices(batch);
      return;
    }
    append_gathered_vertices(mesh_, batch);
  }
  /// After the last vertex: `layout` for a mesh without any (its attribute names).
  void vertices_done(const TriangleMesh& layout) {
    if (streamed_ && !writer_) writer_.emplace(path_, vertices_, triangles_, layout);
    if (!streamed_ && mesh_.attributes.empty()) mesh_.attributes = layout.attributes;
  }
  void add_triangles(const std::vector<Triangle>& batch) {
    if (streamed_)
      writer_->add_triangles(batch.data(), batch.size());
    else
      mesh_.triangles.insert(mesh_.triangles.end(), batch.begin(), batch.end());
  }
  /// The PLY committed; or the whole mesh, to be written.
  TriangleMesh finish() {
    if (streamed_) writer_->commit();
    return std::move(mesh_);
  }

 private:
  std::string path_;
  bool streamed_;
  std::size_t vertices_, triangles_;
  std::optional<io::PlyMeshWriter> writer_;
  TriangleMesh mesh_;
};

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
/// read_parts, scatter or exchange, surface, gather_write, gather and write, or write_pieces).
/// Every rank runs every phase; a phase returns false on every rank when one failed (each failing
/// rank has printed why).
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
    // The point the whole frame is computed about (reconstruct.hpp local_origin), from its
    // bounding box over the parts: each slab is computed about it, as one process would.
    double box[6] = {INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY};  // lo, −hi
    for (const Vec3f& x : all_.positions)
      for (int a = 0; a < 3; ++a) box[a] = std::min(box[a], double(x[a])), box[3 + a] = std::min(box[3 + a], -double(x[a]));
    MPI_Allreduce(MPI_IN_PLACE, box, 6, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    origin_ = local_origin({box[0], box[1], box[2]}, {-box[3], -box[4], -box[5]});
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
    // A PLY output is written as the gather merges the pieces (rank 0 holds a chunk of each);
    // other formats are gathered whole on rank 0 first.
    std::string extension = std::filesystem::path(job_.output).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    streamed_ = !job_.pieces && extension == ".ply";
    report_.particles = double(slab_.size());
    const std::optional<std::string> error = attempt([&] {
      if (slab_.size() == 0) return;  // a slab without particles owns no triangle
      if (job_.pieces) {
        result_ = reconstruct_about(slab_, given_, origin_);
        keep_owned(result_.mesh, d_, rank_);
        piece_ = std::move(result_.mesh);
      } else {
        std::vector<VertexOrderKey> keys;
        result_ = reconstruct_ordered(slab_, given_, keys, origin_);
        part_ = ordered_part(std::move(result_.mesh), std::move(keys), d_, rank_, origin_);
      }
      result_.mesh = {};
    });
    slab_ = {};
    report_.surface_seconds = seconds_since(t);
    report_.owned_vertices =
        double(job_.pieces ? piece_.vertices.size() : part_.written.vertices.size() + part_.foreign.size());
    report_.owned_triangles = double(job_.pieces ? piece_.triangles.size() : part_.triangles.size());
    report_.removed_voids = double(result_.stats.removed_voids);
    report_.removed_blobs = double(result_.stats.removed_blobs);
    report_.dropped_triangles = double(result_.stats.dropped_triangles);
    return all_ok(error, rank_);
  }

  /// The pieces to rank 0. --pieces: every rank writes its own; rank 0 the index. Otherwise the
  /// ordered gather: rank 0 merges the ranks' vertices, then their triangles, into one process's
  /// order, chunk by chunk, writing a PLY as they come and holding the mesh for another format.
  /// Then the ranks' reports to rank 0.
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
    } else {
      error = attempt([&] { gather_ordered_parts(); });
      if (error) {
        // Ranks are waiting on each other's messages: nothing is written, every rank stops.
        fmt::print(stderr, "meniscus: rank {}: error: {}\n", rank_, *error);
        MPI_Abort(MPI_COMM_WORLD, 1);
      }
    }
    stages_.emplace_back(job_.pieces ? "write_pieces" : streamed_ ? "gather_write" : "gather", seconds_since(t));
    report_.peak_bytes = double(peak_resident_bytes());
    reports_.resize(static_cast<std::size_t>(ranks_));
    MPI_Gather(&report_, kReportFields, MPI_DOUBLE, reports_.data(), kReportFields, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    double slowest = 0;
    for (const RankReport& r : reports_) slowest = std::max(slowest, r.surface_seconds);
    stages_.insert(stages_.end() - 1, {"surface", slowest});
    return true;
  }

  /// Rank 0 writes the gathered mesh (unless streamed), the summary and the stats; every rank
  /// returns its exit code.
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
  /// The ordered gather (meniscus/distributed.hpp), every rank's side: rank 0 numbers the
  /// vertices (its own part's from memory, the others' by message) and answers each rank with its
  /// vertices' places; every rank places its part, the ranks agree on the normals' chunks and
  /// exchange the terms of the seam vertices' normals; then rank 0 merges the ranks' vertices and
  /// triangles by index into the mesh.
  void gather_ordered_parts() {
    std::optional<OrderedGather> gather;
    VertexPlaces own, foreign;
    const auto append = [&](VertexPlaces p) {
      own.index.insert(own.index.end(), p.index.begin(), p.index.end());
      own.first_triangle.insert(own.first_triangle.end(), p.first_triangle.begin(), p.first_triangle.end());
    };
    uint64_t totals[2] = {0, 0};  // vertices, triangles
    if (rank_ == 0) {
      gather.emplace(static_cast<std::size_t>(ranks_));
      std::size_t next = 0;
      totals[0] = gather->number_vertices(
          [&](std::size_t r) {
            if (r > 0) return unpack_key_chunk(receive_bytes(int(r), kKeys));
            OrderedGather::KeyChunk c = key_chunk(part_, next);
            next += c.keys.size();
            return c;
          },
          [&](std::size_t r, VertexPlaces places) {
            if (r > 0)
              send_bytes(pack(places), int(r), kPlaced);
            else
              append(std::move(places));
          });
      totals[1] = gather->triangles();
      for (int r = 1; r < ranks_; ++r)
        send_bytes(pack(gather->seam_places(receive_array<VertexOrderKey>(r, kSeams))), r, kSeams);
      foreign = gather->seam_places(part_.foreign);
    } else {
      for (std::size_t first = 0;; first += OrderedGather::kChunk) {
        const OrderedGather::KeyChunk c = key_chunk(part_, first);
        send_bytes(pack(c), 0, kKeys);
        if (c.keys.empty()) break;
        append(unpack_places(receive_bytes(0, kPlaced)));
      }
      send_array(part_.foreign, 0, kSeams);
      foreign = unpack_places(receive_bytes(0, kSeams));
    }
    MPI_Bcast(totals, 2, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    const PlacedPart placed = place_part(part_, own, foreign);
    own = {}, foreign = {};
    std::vector<uint32_t> lo, hi;
    normal_chunk_bounds(placed, std::size_t(totals[1]), lo, hi);
    if (lo.size() > std::size_t(INT_MAX)) throw std::runtime_error("the gather: too many chunks of triangles");
    MPI_Allreduce(MPI_IN_PLACE, lo.data(), int(lo.size()), MPI_UINT32_T, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, hi.data(), int(hi.size()), MPI_UINT32_T, MPI_MAX, MPI_COMM_WORLD);
    const std::size_t stride = normal_stride(lo, hi);
    gather_normals(part_, placed, stride, exchange_terms(foreign_terms(part_, placed, stride, ranks_), ranks_));
    if (rank_ == 0) {
      GatheredMesh out(job_.output, streamed_, std::size_t(totals[0]), std::size_t(totals[1]));
      std::size_t next_vertex = 0, next_triangle = 0;
      gather->merge_vertices(
          [&](std::size_t r) {
            if (r > 0) return unpack_vertex_chunk(receive_bytes(int(r), kVertices));
            OrderedGather::VertexChunk c = vertex_chunk(part_, placed, next_vertex);
            next_vertex += c.index.size();
            return c;
          },
          [&](const TriangleMesh& batch) { out.add_vertices(batch); });
      out.vertices_done(gather->layout());
      part_ = {};
      gather->merge_triangles(
          [&](std::size_t r) {
            if (r > 0) return unpack_triangle_chunk(receive_bytes(int(r), kTriangles));
            OrderedGather::TriangleChunk c = triangle_chunk(placed, next_triangle);
            next_triangle += c.index.size();
            return c;
          },
          [&](const std::vector<Triangle>& batch) { out.add_triangles(batch); });
      mesh_ = out.finish();
      gathered_vertices_ = std::size_t(totals[0]);
    } else {
      for (std::size_t first = 0;; first += OrderedGather::kChunk) {
        const OrderedGather::VertexChunk c = vertex_chunk(part_, placed, first);
        send_bytes(pack(c), 0, kVertices);
        if (c.index.empty()) break;
      }
      part_ = {};
      for (std::size_t first = 0;; first += OrderedGather::kChunk) {
        const OrderedGather::TriangleChunk c = triangle_chunk(placed, first);
        send_bytes(pack(c), 0, kTriangles);
        if (c.index.empty()) break;
      }
    }
  }

  void write_and_report() {
    const auto t4 = std::chrono::steady_clock::now();
    const Params p = result_.params.spacing > 0 ? result_.params : resolve_params(ParticleSet{{Vec3f{}}, {}}, given_);
    // The counts: the gathered mesh's, or with --pieces the pieces' sums (seam vertices in each piece).
    std::size_t vertices = 0, triangles = 0;
    for (const RankReport& r : reports_)
      vertices += std::size_t(r.owned_vertices), triangles += std::size_t(r.owned_triangles);
    if (streamed_) {
      vertices = gathered_vertices_;
      reports_[0].peak_bytes = double(peak_resident_bytes());  // rank 0's peak with the gather and the write
    } else if (!job_.pieces) {
      vertices = gathered_vertices_;
      write_mesh(job_.output, mesh_);
      mesh_ = {};
      stages_.emplace_back("write", seconds_since(t4));
      reports_[0].peak_bytes = double(peak_resident_bytes());  // rank 0's peak with the gather and the write
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
  std::array<double, 3> origin_{};  // the whole frame's local origin
  std::size_t total_particles_ = 0, gathered_vertices_ = 0;
  Decomposition d_;
  ParticleSet slab_;
  OrderedPart part_;          // the owned part for the ordered gather
  TriangleMesh piece_, mesh_;  // the owned piece with --pieces; rank 0's gathered mesh (not a PLY)
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
