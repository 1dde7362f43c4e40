// meniscus — one frame over the ranks of an MPI job (apps/meniscus/mpi_surface.hpp).
#include "mpi_surface.hpp"

#include <fmt/format.h>
#include <mpi.h>
#include <nlohmann/json.hpp>
#include <sys/resource.h>

#include <algorithm>
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

#include "io/atomic_file.hpp"
#include "io/vtu.hpp"
#include "meniscus/distributed.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/reconstruct.hpp"
#include "stage_plan.hpp"

namespace meniscus::cli {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::size_t peak_rss_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return std::size_t(usage.ru_maxrss) * 1024;
}

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
    std::memcpy(v.data(), bytes.data() + at, n * sizeof(T));
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

/// A mesh, its arrays sent as they are (no packed copy): the sizes and attribute names first.
void send_mesh(const TriangleMesh& m, int to, int tag) {
  Writer w;
  w.put(uint64_t(m.vertices.size()));
  w.put(uint64_t(m.triangles.size()));
  w.put(uint64_t(m.normals.size()));
  w.put(uint64_t(m.attributes.size()));
  for (const Attribute& a : m.attributes) {
    w.put_string(a.name);
    w.put(int32_t(a.components));
    w.put(uint8_t(a.integer));
    w.put(uint64_t(a.values.size()));
  }
  send_bytes(w.bytes, to, tag);
  send_raw(m.vertices.data(), m.vertices.size() * sizeof(Vec3f), to, tag);
  send_raw(m.triangles.data(), m.triangles.size() * sizeof(Triangle), to, tag);
  send_raw(m.normals.data(), m.normals.size() * sizeof(Vec3f), to, tag);
  for (const Attribute& a : m.attributes) send_raw(a.values.data(), a.values.size() * sizeof(float), to, tag);
}

TriangleMesh receive_mesh(int from, int tag) {
  const std::vector<char> head = receive_bytes(from, tag);
  Reader r{head};
  TriangleMesh m;
  m.vertices.resize(r.get<uint64_t>());
  m.triangles.resize(r.get<uint64_t>());
  m.normals.resize(r.get<uint64_t>());
  m.attributes.resize(r.get<uint64_t>());
  for (Attribute& a : m.attributes) {
    a.name = r.get_string();
    a.components = r.get<int32_t>();
    a.integer = r.get<uint8_t>() != 0;
    a.values.resize(r.get<uint64_t>());
  }
  receive_raw(m.vertices.data(), m.vertices.size() * sizeof(Vec3f), from, tag);
  receive_raw(m.triangles.data(), m.triangles.size() * sizeof(Triangle), from, tag);
  receive_raw(m.normals.data(), m.normals.size() * sizeof(Vec3f), from, tag);
  for (Attribute& a : m.attributes) receive_raw(a.values.data(), a.values.size() * sizeof(float), from, tag);
  return m;
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

enum Tag : int { kParticles = 1, kPiece = 2 };

/// What each rank reports to rank 0 for the stats.
struct RankReport {
  double particles = 0, owned_vertices = 0, owned_triangles = 0, surface_seconds = 0, peak_bytes = 0;
};

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

int run_surface_mpi(const MpiSession& session, const MpiJob& job) {
  const int rank = session.rank(), ranks = session.size();
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::pair<std::string, double>> stages;  // rank 0's view of the job

  // Rank 0 reads the frame, makes the frame-wide estimates on it and cuts it into slabs.
  ParticleSet all;
  double estimates[3] = {0, 0, 0};  // spacing, rest density, reference speed
  std::size_t total_particles = 0;
  std::optional<std::string> error;
  if (rank == 0)
    error = attempt([&] {
      all = read_particles(job.input, job.read);
      const Params est = resolve_frame_estimates(all, job.params);
      estimates[0] = est.spacing, estimates[1] = est.rest_density, estimates[2] = est.velocity_reference;
      total_particles = all.size();
    });
  if (!all_ok(error, rank)) return 1;
  stages.emplace_back("read", seconds_since(t0));
  MPI_Bcast(estimates, 3, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  Params given = job.params;
  given.spacing = estimates[0], given.rest_density = estimates[1], given.velocity_reference = estimates[2];

  // The slabs (every rank computes the same cuts from the resolved parameters rank 0 sends).
  const auto t1 = std::chrono::steady_clock::now();
  Decomposition d;
  std::vector<double> cuts_message(std::size_t(ranks) + 1);  // axis, halo, cuts
  if (rank == 0)
    error = attempt([&] {
      d = decompose(all, resolve_params(all, given), ranks);
      cuts_message[0] = d.axis, cuts_message[1] = d.halo;
      std::copy(d.cuts.begin(), d.cuts.end(), cuts_message.begin() + 2);
    });
  if (!all_ok(error, rank)) return 1;
  MPI_Bcast(cuts_message.data(), ranks + 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  d.ranks = ranks, d.axis = int(cuts_message[0]), d.halo = cuts_message[1];
  d.cuts.assign(cuts_message.begin() + 2, cuts_message.end());

  // Scatter: each rank its slab with its halo, attributes travelling with the particles.
  ParticleSet slab;
  if (rank == 0) {
    for (int r = 1; r < ranks; ++r) send_bytes(pack(slab_particles(all, d, r)), r, kParticles);
    slab = slab_particles(all, d, 0);
    ParticleSet().positions.swap(all.positions);
    all = {};
  } else {
    error = attempt([&] { slab = unpack_particles(receive_bytes(0, kParticles)); });
  }
  if (!all_ok(error, rank)) return 1;
  stages.emplace_back("scatter", seconds_since(t1));

  // Every rank surfaces its slab and keeps the triangles it owns.
  const auto t2 = std::chrono::steady_clock::now();
  TriangleMesh piece;
  Result result;
  RankReport report;
  report.particles = double(slab.size());
  error = attempt([&] {
    if (slab.size() == 0) return;  // a slab without particles owns no triangle
    result = reconstruct(slab, given);
    keep_owned(result.mesh, d, rank);
    piece = std::move(result.mesh);
    result.mesh = {};
  });
  slab = {};
  report.surface_seconds = seconds_since(t2);
  report.owned_vertices = double(piece.vertices.size());
  report.owned_triangles = double(piece.triangles.size());
  if (!all_ok(error, rank)) return 1;

  // --pieces: every rank writes its own; rank 0 the index.
  const auto t3 = std::chrono::steady_clock::now();
  std::vector<TriangleMesh> pieces;
  if (job.pieces) {
    error = attempt([&] { io::write_vtp_mesh(piece_path(job.output, rank), piece); });
    if (!all_ok(error, rank)) return 1;
    if (rank == 0) {
      std::vector<std::string> names;
      for (int r = 0; r < ranks; ++r) names.push_back(std::filesystem::path(piece_path(job.output, r)).filename().string());
      error = attempt([&] { io::write_pvtp_index(job.output, names, piece); });
    }
    if (!all_ok(error, rank)) return 1;
    piece = {};
  } else if (rank == 0) {
    pieces.push_back(std::move(piece));
    for (int r = 1; r < ranks; ++r) pieces.push_back(receive_mesh(r, kPiece));
  } else {
    send_mesh(piece, 0, kPiece);
    piece = {};
  }
  stages.emplace_back(job.pieces ? "write_pieces" : "gather", seconds_since(t3));
  report.peak_bytes = double(peak_rss_bytes());
  std::vector<RankReport> reports(static_cast<std::size_t>(ranks));
  MPI_Gather(&report, 5, MPI_DOUBLE, reports.data(), 5, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  double slowest = 0;
  for (const RankReport& r : reports) slowest = std::max(slowest, r.surface_seconds);
  stages.insert(stages.end() - 1, {"surface", slowest});

  // Rank 0 welds and writes.
  int code = 0;
  if (rank == 0) {
    error = attempt([&] {
      const auto t4 = std::chrono::steady_clock::now();
      const Params p = result.params.spacing > 0 ? result.params : resolve_params(ParticleSet{{Vec3f{}}, {}}, given);
      // The counts: the welded mesh's, or with --pieces the pieces' sums (seam vertices in each piece).
      std::size_t vertices = 0, triangles = 0;
      for (const RankReport& r : reports) vertices += std::size_t(r.owned_vertices), triangles += std::size_t(r.owned_triangles);
      if (!job.pieces) {
        const TriangleMesh mesh = weld_pieces(std::move(pieces));
        vertices = mesh.vertices.size();
        pieces.clear();
        stages.emplace_back("weld", seconds_since(t4));
        const auto t5 = std::chrono::steady_clock::now();
        write_mesh(job.output, mesh);
        stages.emplace_back("write", seconds_since(t5));
      }
      double total = 0, peak = 0;
      for (const auto& [name, s] : stages) total += s;
      for (const RankReport& r : reports) peak = std::max(peak, r.peak_bytes);
      if (!job.quiet) {
        fmt::print(stderr, "{} particles → {} vertices, {} triangles in {:.3f}s on {} ranks (slabs along {}, halo {:.4g} = "
                           "{:.1f} spacings), peak memory per rank {:.0f} MB at most\n",
                   total_particles, vertices, triangles, total, ranks, "xyz"[d.axis], d.halo,
                   d.halo / p.spacing, peak / 1e6);
        std::string line;
        for (const auto& [name, s] : stages) line += fmt::format("{}{} {:.3f}s", line.empty() ? "" : ", ", name, s);
        fmt::print(stderr, "  {}\n", line);
        for (int r = 0; r < ranks; ++r) {
          const RankReport& q = reports[std::size_t(r)];
          fmt::print(stderr, "  rank {}: {:.0f} particles with its halo, owns {:.0f} triangles, surfaced in {:.3f}s, peak {:.0f} MB\n",
                     r, q.particles, q.owned_triangles, q.surface_seconds, q.peak_bytes / 1e6);
        }
        fmt::print(stderr, "wrote {}{}{}\n", job.output,
                   job.pieces ? fmt::format(" and its {} pieces {} … (vertices counted per piece: the seams twice)",
                                            ranks, piece_path(job.output, 0))
                              : "",
                   job.stats.empty() ? "" : ", " + job.stats);
      }
      if (!job.stats.empty()) {
        Result summary;
        summary.params = p;
        summary.stats = result.stats;
        summary.stats.particles = total_particles;
        summary.stats.vertices = vertices;
        summary.stats.triangles = triangles;
        summary.stats.peak_memory_bytes = std::size_t(peak);
        summary.stats.stages.clear();
        for (const auto& [name, s] : stages) summary.stats.stages.push_back({name, s});
        nlohmann::ordered_json j = nlohmann::ordered_json::parse(stats_to_json(summary));
        j["ranks"] = ranks;
        j["decomposition"] = {{"axis", std::string(1, "xyz"[d.axis])}, {"cuts", d.cuts}, {"halo", d.halo},
                              {"halo_spacings", d.halo / p.spacing}};
        nlohmann::ordered_json per_rank = nlohmann::ordered_json::array();
        for (int r = 0; r < ranks; ++r) {
          const RankReport& q = reports[std::size_t(r)];
          per_rank.push_back({{"rank", r}, {"particles_with_halo", q.particles}, {"owned_vertices", q.owned_vertices},
                              {"owned_triangles", q.owned_triangles}, {"surface_seconds", q.surface_seconds},
                              {"peak_memory_bytes", q.peak_bytes}});
        }
        j["per_rank"] = per_rank;
        const std::string text = j.dump(2) + "\n";
        io::AtomicFile file(job.stats);
        file.write(text.data(), text.size());
        file.commit();
      }
    });
    if (error) {
      fmt::print(stderr, "meniscus: error: {}\n", *error);
      code = 1;
    }
  }
  MPI_Bcast(&code, 1, MPI_INT, 0, MPI_COMM_WORLD);
  return code;
}

}  // namespace meniscus::cli
