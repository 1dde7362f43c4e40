// meniscus CLI — `meniscus render`: a preview picture (.png) of a mesh or a mesh sequence.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <optional>
#include <tuple>
#include <utility>

#include "cli.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/render.hpp"
#include "meniscus/resources.hpp"
#include "meniscus/sequence.hpp"
#include "render.hpp"

namespace meniscus::cli {

namespace {

/// The largest picture written: PNG holds more, but a picture of a billion pixels is a mistake.
constexpr std::size_t kMaxPicturePixels = std::size_t(1) << 30;
/// Per output pixel while a tile is drawn: 2×2 samples of a primitive id and a depth, and slack.
constexpr double kSampleBytes = 40;

/// A growing axis-aligned box of finite points.
struct Box3 {
  Vec3f lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  void add(Vec3f p) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) lo = min(lo, p), hi = max(hi, p);
  }
  bool valid() const { return lo.x <= hi.x; }
};

double mesh_bytes(const TriangleMesh& m) {
  double bytes = double(m.vertices.size() + m.normals.size()) * sizeof(Vec3f) + double(m.triangles.size()) * sizeof(Triangle);
  for (const Attribute& a : m.attributes) bytes += double(a.values.size()) * sizeof(float);
  return bytes;
}


/// "960x720" → {960, 720}; each side 1 ..= 8192.
std::pair<int, int> parse_size(const std::string& text) {
  const std::size_t x = text.find_first_of("xX");
  const auto side = [&](std::string_view digits) {
    if (digits.empty() || digits.size() > 5 || digits.find_first_not_of("0123456789") != std::string_view::npos) return 0;
    return std::stoi(std::string(digits));
  };
  const int w = x == std::string::npos ? 0 : side(std::string_view(text).substr(0, x));
  const int h = x == std::string::npos ? 0 : side(std::string_view(text).substr(x + 1));
  if (w < 1 || h < 1 || w > 8192 || h > 8192)
    throw InvalidParameter(fmt::format("--size '{}': expected WIDTHxHEIGHT with each side in 1 ..= 8192, e.g. 960x720", text));
  return {w, h};
}

/// "lo,hi" → {lo, hi} with lo < hi.
std::array<float, 2> parse_range(const std::string& text) {
  const std::size_t comma = text.find(',');
  float lo = 0, hi = 0;
  bool ok = comma != std::string::npos;
  if (ok) {
    try {
      std::size_t used_lo = 0, used_hi = 0;
      const std::string a = text.substr(0, comma), b = text.substr(comma + 1);
      lo = std::stof(a, &used_lo);
      hi = std::stof(b, &used_hi);
      ok = used_lo == a.size() && used_hi == b.size() && std::isfinite(lo) && std::isfinite(hi) && lo < hi;
    } catch (const std::exception&) {
      ok = false;
    }
  }
  if (!ok) throw InvalidParameter(fmt::format("--range '{}': expected LO,HI with LO < HI, e.g. 0,2.5", text));
  return {lo, hi};
}

}  // namespace

/// Pictures of a mesh or a mesh sequence: one tile per frame (a row of --turntable views each),
/// all frames framed on their common bounding box and coloured over one range.
int run_render(const RenderArgs& a) {
  RenderOptions options;
  std::tie(options.width, options.height) = parse_size(a.size);
  options.yaw_degrees = a.yaw;
  options.pitch_degrees = a.pitch;
  options.color_attribute = a.color_by;
  if (!a.range.empty()) options.color_range = parse_range(a.range);
  if (!a.range.empty() && a.color_by.empty()) throw InvalidParameter("--range needs --color-by");
  if (!(a.max_memory_gb >= 0 && a.max_memory_gb <= 1e6))
    throw InvalidParameter(fmt::format("--max-memory {:g}: must be a number from 0 to 1e+06 (0: 90 % of the memory "
                                       "granted)", a.max_memory_gb));
  if (a.turntable < 1 || a.turntable > 64)
    throw InvalidParameter(fmt::format("--turntable {}: expected 1 ..= 64 views", a.turntable));
  options.validate();
  if (const std::string ext = std::filesystem::path(a.output).extension().string(); ext != ".png" && ext != ".PNG")
    throw InvalidParameter(fmt::format("output '{}': render writes PNG pictures (name it .png)", printable(a.output)));

  // The files: one mesh, or the frames of a pattern (with a particle pattern beside it).
  const std::optional<FramePattern> mesh_pattern = parse_frame_pattern(a.mesh);
  const std::optional<FramePattern> particle_pattern =
      a.particles.empty() ? std::nullopt : parse_frame_pattern(a.particles);
  std::vector<std::pair<std::string, std::string>> files;  // mesh, particles
  std::vector<int> frames;
  if (mesh_pattern) {
    frames = a.frames.empty() ? discover_frames(*mesh_pattern) : parse_frame_ranges(a.frames);
    if (frames.empty())
      throw IoError(fmt::format("no file matches '{}' (the placeholder is replaced by frame numbers)", printable(a.mesh)));
    for (const int frame : frames)
      files.emplace_back(mesh_pattern->format(frame), particle_pattern ? particle_pattern->format(frame) : a.particles);
  } else {
    if (!a.frames.empty()) throw InvalidParameter("--frames needs a mesh pattern with a frame placeholder (####, {} or %04d)");
    if (particle_pattern)
      throw InvalidParameter(fmt::format("--particles '{}' has a frame placeholder but the mesh is a single file", a.particles));
    files.emplace_back(a.mesh, a.particles);
  }
  const std::size_t tiles = files.size() * std::size_t(a.turntable);
  if (tiles > 256)
    throw InvalidParameter(fmt::format("{} frames × {} views = {} pictures: at most 256 (select fewer with --frames "
                                       "1-240:10)", files.size(), a.turntable, tiles));
  // The picture's memory, before anything is read or drawn: every tile (3 bytes a pixel) and the
  // joined picture, plus one tile's 2×2 samples (primitive and depth) while it is drawn.
  const double pixels = double(options.width) * double(options.height);
  if (pixels * double(tiles) > double(kMaxPicturePixels))
    throw InvalidParameter(fmt::format("{} tiles of {}×{} make a picture of {:.3g} million pixels: at most {:.0f} million "
                                       "(use a smaller --size or fewer --frames/--turntable views)",
                                       tiles, options.width, options.height, pixels * double(tiles) / 1e6,
                                       double(kMaxPicturePixels) / 1e6));
  const double limit = memory_limit_bytes(a.max_memory_gb);
  const double picture_bytes = 6 * pixels * double(tiles) + kSampleBytes * pixels;
  if (picture_bytes > limit)
    throw ResourceError(fmt::format("the picture would need {} ({} tiles of {}×{}), more than the {} allowed ({}); use "
                                    "a smaller --size, fewer tiles, or raise --max-memory",
                                    human_bytes(picture_bytes), tiles, options.width, options.height,
                                    human_bytes(limit), memory_limit(a.max_memory_gb).source));

  // Every file before any work: the picture must not be one of the files read.
  {
    std::vector<RunFile> run = {{a.output, "-o", true}};
    for (const auto& [mesh_file, particle_file] : files)
      run.push_back({mesh_file, "a mesh", false}), run.push_back({particle_file, "--particles", false});
    check_run_files(run);
  }

  // Read everything first, so a missing file or attribute fails before any picture is made.
  std::vector<TriangleMesh> meshes;
  std::vector<ParticleSet> particles;
  Box3 box;
  double held = picture_bytes;  // the meshes and particles read so far share the rest of the limit
  for (const auto& [mesh_file, particle_file] : files) {
    meshes.push_back(read_mesh(mesh_file, std::max(limit - held, 1.0) / 1e9));
    held += mesh_bytes(meshes.back());
    ReadOptions read;
    read.max_memory_gb = std::max(limit - held, 1.0) / 1e9;
    particles.push_back(particle_file.empty() ? ParticleSet{} : read_particles(particle_file, read));
    held += double(particles.back().size()) * sizeof(Vec3f);
    for (const Vec3f& v : meshes.back().vertices) box.add(v);
    if (meshes.back().vertices.empty())
      for (const Vec3f& v : particles.back().positions) box.add(v);
  }
  std::optional<std::array<float, 2>> auto_range;
  ColorMapping mapping = ColorMapping::scalar;
  if (!a.color_by.empty()) {
    for (std::size_t i = 0; i < meshes.size(); ++i) {
      const Attribute* attribute = meshes[i].find(a.color_by);
      if (attribute == nullptr) {
        std::string available;
        for (const Attribute& at : meshes[i].attributes)
          if (at.components == 1 || at.components == 3) available += (available.empty() ? "" : ", ") + at.name;
        throw InvalidParameter(fmt::format("--color-by '{}': {} has no such vertex attribute (it has: {})", a.color_by,
                                           files[i].first, available.empty() ? "none" : available));
      }
      mapping = color_mapping(*attribute);
      if (const auto r = color_value_range(*attribute))
        auto_range = auto_range ? std::array{std::min((*auto_range)[0], (*r)[0]), std::max((*auto_range)[1], (*r)[1])} : *r;
    }
    // One range for every frame, so a colour means the same value in every tile.
    if (!options.color_range && auto_range && (*auto_range)[0] < (*auto_range)[1]) options.color_range = auto_range;
  }
  if (mesh_pattern && box.valid()) options.frame_bounds = Bounds{box.lo, box.hi};
  // The up axis (auto): a Houdini file's convention, else gravity in the first frame's velocities
  // (the mesh's transferred ones, or the particles') and in how its particles settle; a surface's
  // own vertices say nothing of the kind (a pool's floor and top weigh the same), so they are not used.
  UpAxis up{a.up == "auto" ? 2 : a.up[0] - 'x', "--up"};
  if (a.up == "auto") {
    const std::string lower = [&] {
      std::string l = files.front().first;
      for (char& c : l) c = char(std::tolower(static_cast<unsigned char>(c)));
      return l;
    }();
    const bool houdini = lower.ends_with(".bgeo") || lower.ends_with(".bgeo.gz") || lower.ends_with(".bgeo.sc") ||
                         lower.ends_with(".sc");
    const auto velocity_of = [](const auto& set) {
      const Attribute* v = set.find("velocity");
      return v != nullptr ? v : set.find("v");
    };
    const Attribute* velocity = velocity_of(meshes.front());
    if (velocity == nullptr) velocity = velocity_of(particles.front());
    up = guess_up_axis(particles.front().positions, velocity, houdini ? "bgeo" : "");
  }
  options.up = up.direction();

  std::vector<Image> images;
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    RenderOptions view = options;
    view.particles = particles[i].size() ? &particles[i] : nullptr;
    images.push_back(render_turntable(meshes[i], view, a.turntable));
  }
  // Frames side by side; with a turntable, one row of views per frame.
  const Image picture = join_images(images, a.turntable == 1 ? int(images.size()) : 1);
  make_parent_dirs(a.output);
  write_png(a.output, picture);
  if (!a.quiet) {
    if (!a.color_by.empty()) {
      if (mapping == ColorMapping::rgb)
        fmt::print(stderr, "coloured by '{}' as RGB\n", a.color_by);
      else if (options.color_range)
        fmt::print(stderr, "coloured by '{}'{} through viridis: {:.6g} (purple) .. {:.6g} (yellow)\n", a.color_by,
                   mapping == ColorMapping::magnitude ? " (magnitude)" : "", (*options.color_range)[0],
                   (*options.color_range)[1]);
    }
    fmt::print(stderr, "wrote {} ({}×{}: {} frame(s) × {} view(s)), up axis {} ({})\n", printable(a.output),
               picture.width, picture.height, meshes.size(), a.turntable, up.name(),
               up.reason == "--up" ? "--up" : up.reason + "; --up sets it");
  }
  return 0;
}

CLI::App* add_render_command(CLI::App& app, RenderArgs& render) {
  CLI::App* cmd = app.add_subcommand("render", "preview picture (.png) of a mesh or a mesh sequence");
  cmd->add_option("mesh", render.mesh, "mesh file, or a sequence pattern (mesh_####.ply): one tile per frame")->required();
  cmd->add_option("-o,--output", render.output, "picture to write (.png)")->required();
  cmd->add_option("--size", render.size, "size of each tile, WIDTHxHEIGHT, each side 1 to 8192")->capture_default_str();
  cmd->add_option("--up", render.up,
                  "up axis; auto: y for Houdini files, else the way gravity shows in the velocities (and in the "
                  "--particles), else z")
      ->check(CLI::IsMember({"auto", "x", "y", "z"}))->capture_default_str();
  cmd->add_option("--yaw", render.yaw, "camera azimuth around the up axis, degrees")->capture_default_str();
  cmd->add_option("--pitch", render.pitch, "camera elevation, degrees in [-89, 89]")->capture_default_str();
  cmd->add_option("--particles", render.particles,
                  "overlay these particles as dots, hidden where the surface is in front (a pattern for a sequence)");
  cmd->add_option("--color-by", render.color_by,
                  "colour by a vertex attribute: scalar or vector magnitude through viridis, colours as RGB");
  cmd->add_option("--range", render.range, "values at the ends of the colormap, LO,HI (default: min,max over all frames)");
  cmd->add_option("--turntable", render.turntable, "N views at evenly spaced azimuths, side by side, 1 to 64")
      ->capture_default_str();
  cmd->add_option("--frames", render.frames, "frames of a sequence: 1-240, 1-240:10, 1,5,10-20 (default: all found)");
  cmd->add_option("--max-memory", render.max_memory_gb,
                  "refuse pictures and meshes past this many GB (default 90 % of the memory granted)");
  cmd->add_flag("-q,--quiet", render.quiet, "print nothing");
  return cmd;
}

}  // namespace meniscus::cli
