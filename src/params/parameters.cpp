// meniscus — the table of parameters (parameters.hpp): one entry per setting, with the code that
// reads and writes its Params member.
#include "meniscus/parameters.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "meniscus/config.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"

namespace meniscus {

namespace {

using nlohmann::json;

constexpr double kUnbounded = std::numeric_limits<double>::infinity();
/// Sweep counts above this are a typing error, not a schedule: 10,000 sweeps of a frame take hours.
constexpr double kMaxSweeps = 10000;
/// Worker threads beyond this multiple of the CPUs only cost memory (each has its own stacks and
/// buffers); 2^31 of them would exhaust any machine before the first stage.
constexpr double kThreadsPerCpu = 4;

using Getter = json (*)(const Params&);
using Setter = void (*)(Params&, const json&);

struct Entry {
  ParamSpec spec;
  Getter get;
  Setter set;
};

#define MENISCUS_MEMBER(member) \
  [](const Params& p) -> json { return p.member; }, [](Params& p, const json& v) { v.get_to(p.member); }

const std::vector<Entry>& entries() {
  static const std::vector<Entry> table = [] {
    std::vector<Entry> t;
    const auto number = [&](std::string_view key, std::string_view group, double min, double max, bool min_open,
                            std::string_view zero, std::string_view unit, std::string_view help, Getter get,
                            Setter set, std::string_view option = "*") {
      ParamSpec s;
      s.key = key, s.type = ParamType::number, s.group = group, s.min = min, s.max = max, s.min_open = min_open;
      s.zero = zero, s.unit = unit, s.help = help;
      s.option = option;
      t.push_back({s, get, set});
    };
    const auto integer = [&](std::string_view key, std::string_view group, double max, std::string_view zero,
                             std::string_view unit, std::string_view help, Getter get, Setter set) {
      ParamSpec s;
      s.key = key, s.type = ParamType::integer, s.group = group, s.min = 0, s.max = max, s.zero = zero, s.unit = unit;
      s.help = help, s.option = "*";
      t.push_back({s, get, set});
    };
    const auto other = [&](std::string_view key, ParamType type, std::string_view group, std::string_view help,
                           Getter get, Setter set, std::vector<std::string_view> choices = {}, std::size_t count = 0) {
      ParamSpec s;
      s.key = key, s.type = type, s.group = group, s.help = help, s.choices = std::move(choices), s.count = count;
      s.option = "*";
      t.push_back({s, get, set});
    };

    // --- geometry
    number("spacing", "geometry", 0, kUnbounded, false, "estimated from the particles", "length",
           "particle separation d (Houdini's particle separation)", MENISCUS_MEMBER(spacing));
    number("voxel_size", "geometry", 0, kUnbounded, false, "d / (2·detail)", "length",
           "field resolution h (Marching Tiles: a tile period of 2h, the same sample density)",
           MENISCUS_MEMBER(voxel_size));
    number("detail", "geometry", 0, 8, true, "", "", "resolution multiplier: voxel size d / (2·detail); 2 ≈ 4× the triangles",
           [](const Params& p) -> json { return p.detail; },
           [](Params& p, const json& v) { apply_detail(p, v.get<double>()); });
    number("r_inner", "geometry", 0, kUnbounded, false, "0.5·r_outer", "length",
           "vertices stay at least this far from their particle", MENISCUS_MEMBER(r_inner));
    number("r_outer", "geometry", 0, kUnbounded, false, "r_outer_factor·d", "length",
           "initial surface radius around each particle", MENISCUS_MEMBER(r_outer));
    number("r_outer_factor", "geometry", 0, 4, true, "", "spacings", "r_outer in spacings when r_outer is 0 (presets set it)",
           MENISCUS_MEMBER(r_outer_factor), "");
    other("extract", ParamType::choice, "geometry", "extractor: tiles (Marching Tiles), cubes, tetrahedra",
          [](const Params& p) -> json { return to_string(p.extract); },
          [](Params& p, const json& v) { p.extract = parse_extractor(v.get<std::string>()); },
          {"tiles", "cubes", "tetrahedra"});
    other("keep_voids", ParamType::flag, "geometry", "keep interior voids smaller than (2 d)³ (removed by default)",
          MENISCUS_MEMBER(keep_voids));
    other("fill_pinholes", ParamType::flag, "geometry",
          "bridge the pinholes of thin sheets: a particle added in each hole that a ring of touching particles "
          "encloses, up to 1.2 d from its middle to the ring; never joins droplets (docs/method.md)",
          MENISCUS_MEMBER(fill_pinholes));
    other("close_handles", ParamType::flag, "geometry",
          "close the small handles of the extracted surface that enclose air (pinholes through sheets, tunnels "
          "through thin water): each cut and capped before the smoothing; never cuts water, never joins droplets; "
          "CPU backend (docs/method.md)",
          MENISCUS_MEMBER(close_handles));

    // --- field method
    other("field", ParamType::choice, "field", "field method: distance, metaball, sph, zhu-bridson, anisotropic (docs/fields.md)",
          [](const Params& p) -> json { return to_string(p.field); },
          [](Params& p, const json& v) { p.field = parse_field(v.get<std::string>()); },
          {"distance", "metaball", "sph", "zhu-bridson", "anisotropic"});
    number("iso", "field", 0, kUnbounded, false, "derived for the field method", "",
           "level of the field (metaball/sph/anisotropic: density threshold; zhu-bridson: particle radius)",
           MENISCUS_MEMBER(iso));
    number("kernel_radius", "field", 0, kUnbounded, false, "2 d", "length", "support radius of the field kernels",
           MENISCUS_MEMBER(kernel_radius));
    number("rest_density", "field", 0, kUnbounded, false, "the median density of the frame", "",
           "rest density ρ₀ of particles with a density but no mass (sph/anisotropic volumes d³·ρ₀/ρ)",
           MENISCUS_MEMBER(rest_density));
    number("smooth_particles", "field", -1, 1, false, "derived, 0.3 with --field anisotropic and 0 otherwise", "",
           "λ in [0, 1]: Laplacian smoothing of the particle positions before the field", MENISCUS_MEMBER(smooth_particles));

    // --- smoothing
    integer("steps_a", "smoothing", kMaxSweeps, "", "sweeps", "constrained graph-Laplacian sweeps", MENISCUS_MEMBER(steps_a));
    integer("steps_b", "smoothing", kMaxSweeps, "", "sweeps", "constrained bilaplacian sweeps", MENISCUS_MEMBER(steps_b));
    integer("steps_free", "smoothing", kMaxSweeps, "", "sweeps",
            "unconstrained bilaplacian sweeps at the end: smoother normals, vertices up to about 0.1 d out of their "
            "shells (no particle outside); 0 keeps every vertex in its shell",
            MENISCUS_MEMBER(steps_free));
    number("relax", "smoothing", 0, 1, false, "1", "", "relaxation ω of the A sweeps", MENISCUS_MEMBER(relax));
    t.back().spec.why = "Jacobi sweeps diverge when over-relaxed";
    number("relax_b", "smoothing", 0, 1, true, "", "",
           "largest damping of the B sweeps; each vertex takes at most its stable one", MENISCUS_MEMBER(relax_b));
    other("solver", ParamType::choice, "smoothing", "sweeps: chebyshev (Jacobi, the A sweeps accelerated) or jacobi (plain); gauss-seidel is refused",
          [](const Params& p) -> json { return to_string(p.solver); },
          [](Params& p, const json& v) { p.solver = parse_solver(v.get<std::string>()); }, {"chebyshev", "jacobi"});
    integer("rebuild_b", "smoothing", kMaxSweeps, "once, after the A sweeps", "sweeps",
            "rebuild the B operator every k sweeps", MENISCUS_MEMBER(rebuild_b));
    other("velocity_weighted", ParamType::flag, "smoothing",
          "smooth fast (splashing) fluid less than calm fluid; needs a velocity attribute (v, vel, velocity)",
          MENISCUS_MEMBER(velocity_weighted));
    number("velocity_reference", "smoothing", 0, kUnbounded, false, "the 95th percentile of the particle speeds", "speed",
           "speed at which the smoothing reaches its minimum", MENISCUS_MEMBER(velocity_reference));
    number("velocity_min_weight", "smoothing", 0, 1, true, "", "", "smallest smoothing factor of fast fluid",
           MENISCUS_MEMBER(velocity_min_weight));
    number("temporal_smoothing", "smoothing", 0, 0.5, false, "", "",
           "a sequence's frames: weight w of the frames either side in each particle's position, matched by the "
           "'id' attribute — (1 − 2w)·x + w·(x₋ + x₊), the shift at most r_inner/2; calm water stops shimmering, "
           "steady motion is kept; 0: off (docs/method.md)",
           MENISCUS_MEMBER(temporal_smoothing));

    // --- post-processing
    number("erode", "post-processing", 0, kUnbounded, false, "", "length",
           "move the finished surface inwards along its normals (warns above h/2, counts folded triangles)",
           MENISCUS_MEMBER(erode));
    integer("min_particles", "post-processing", 1e9, "keep every droplet", "particles",
            "drop surface components enclosing fewer particles than this (strays, particles stuck in a wall)",
            MENISCUS_MEMBER(min_particles));
    other("particle_box", ParamType::numbers, "post-processing",
          "xmin,ymin,zmin,xmax,ymax,zmax: surface only the particles inside this box", MENISCUS_MEMBER(particle_box), {}, 6);
    other("clip_box", ParamType::numbers, "post-processing",
          "xmin,ymin,zmin,xmax,ymax,zmax: cut the finished surface by this box, open along the cut",
          MENISCUS_MEMBER(clip_box), {}, 6);
    other("clip_cap", ParamType::flag, "post-processing", "close the clip box's cut with the box's faces (the mesh stays watertight)",
          MENISCUS_MEMBER(clip_cap));
    number("decimate", "post-processing", 0, 1, false, "keep every triangle", "spacings",
           "simplify the mesh: the full surface's points held within this many spacings, the surfaces within "
           "1.25x it anywhere (e.g. 0.02)",
           MENISCUS_MEMBER(decimate));
    other("transfer", ParamType::names, "post-processing", "particle attributes to carry onto the vertices",
          MENISCUS_MEMBER(transfer));
    number("transfer_radius", "post-processing", 0, kUnbounded, false, "2 d", "length",
           "radius of the transfer kernel (1 − (r/R)²)³; the nearest particle where none is inside",
           MENISCUS_MEMBER(transfer_radius));

    // --- execution
    integer("threads", "execution", 0 /* parameter_max */, "the CPUs granted", "",
            "worker threads (by default the CPU affinity, or SLURM_CPUS_PER_TASK where Slurm grants fewer)",
            MENISCUS_MEMBER(threads));
    other("backend", ParamType::choice, "execution", "where to run: auto (cuda when a device is there), cpu, cuda",
          [](const Params& p) -> json { return to_string(p.backend); },
          [](Params& p, const json& v) { p.backend = parse_backend(v.get<std::string>()); }, {"auto", "cpu", "cuda"});
    number("max_memory_gb", "execution", 0, 1e6, false, "90 % of the memory granted", "GB",
           "refuse work, and stop reading, past this much memory (the grant: RAM, cgroup, Slurm's --mem)",
           MENISCUS_MEMBER(max_memory_gb), "--max-memory");

    // --- the controls: they set other parameters
    other("preset", ParamType::choice, "controls", "preview (fast), production (the defaults) or droplets (keeps thin "
          "sheets and lone droplets)",
          [](const Params&) -> json { return nullptr; },
          [](Params& p, const json& v) { apply_preset(p, v.get<std::string>()); }, {"preview", "production", "droplets"});
    number("smoothness", "controls", 0, 1, false, "", "", "0 (as extracted) .. 1 (twice the sweeps); 0.5 = the default schedule",
           [](const Params&) -> json { return nullptr; },
           [](Params& p, const json& v) { apply_smoothness(p, v.get<double>()); });
    for (Entry& e : t) {
      if (e.spec.key == "preset" || e.spec.key == "smoothness") e.spec.control = true;
    }
    return t;
  }();
  return table;
}

#undef MENISCUS_MEMBER

/// The options' names: "--" and the key with '-' for '_', made once (string_views into them).
const std::vector<std::string>& option_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const Entry& e : entries()) {
      std::string o = "--" + std::string(e.spec.key);
      std::replace(o.begin(), o.end(), '_', '-');
      out.push_back(o);
    }
    return out;
  }();
  return names;
}

const std::vector<ParamSpec>& specs() {
  static const std::vector<ParamSpec> table = [] {
    std::vector<ParamSpec> out;
    for (std::size_t i = 0; i < entries().size(); ++i) {
      ParamSpec s = entries()[i].spec;
      if (s.option == "*") s.option = option_names()[i];
      out.push_back(s);
    }
    return out;
  }();
  return table;
}

const Entry& entry_of(const ParamSpec& spec) {
  const std::size_t i = std::size_t(&spec - specs().data());
  if (i >= specs().size()) throw std::logic_error("a ParamSpec that is not parameter_table()'s");
  return entries()[i];
}

std::string shown(const json& value) {
  std::string text = value.dump();
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return text;
}

std::string number_text(double v) { return fmt::format("{:g}", v); }

/// "must be <accepted values>", with the range's reason where the table gives one.
std::string must_be(const ParamSpec& s) {
  std::string accepts = accepted_values(s);
  if (s.key == "threads") accepts += fmt::format(" ({:g} on this machine)", parameter_max(s));
  return s.why.empty() ? "must be " + accepts : fmt::format("must be {}: {}", accepts, s.why);
}

bool in_range(const ParamSpec& s, double v) {
  return std::isfinite(v) && (s.min_open ? v > s.min : v >= s.min) && v <= parameter_max(s);
}

std::vector<double> numbers_of(const ParamSpec& spec, const json& value, std::string_view written) {
  std::vector<double> out;
  const auto refuse = [&] {
    throw InvalidParameter(std::string(spec.key), written.empty() ? shown(value) : std::string(written),
                           "expected " + accepted_values(spec));
  };
  if (value.is_string()) {
    const std::string text = value.get<std::string>();
    if (text.empty()) return out;
    return parse_parameter_text(spec, text).get<std::vector<double>>();
  }
  if (!value.is_array()) refuse();
  for (const json& item : value) {
    if (!item.is_number()) refuse();
    out.push_back(item.get<double>());
  }
  if (!out.empty() && out.size() != spec.count) refuse();
  return out;
}

}  // namespace

const std::vector<ParamSpec>& parameter_table() { return specs(); }

const ParamSpec* find_parameter(std::string_view name) {
  std::string key(name.starts_with("--") ? name.substr(2) : name);
  std::replace(key.begin(), key.end(), '-', '_');
  for (const ParamSpec& s : specs())
    if (s.key == key || (!s.option.empty() && s.option == name)) return &s;
  return nullptr;
}

double parameter_max(const ParamSpec& spec) {
  if (spec.key == "threads") {
    const unsigned cpus = std::max(1u, std::thread::hardware_concurrency());
    return kThreadsPerCpu * cpus;
  }
  return spec.max;
}

std::string accepted_values(const ParamSpec& s) {
  std::string zero;
  if (!s.zero.empty()) zero = s.key == "smooth_particles" ? fmt::format(" (or −1: {})", s.zero) : fmt::format(" (0: {})", s.zero);
  const double max = parameter_max(s);
  switch (s.type) {
    case ParamType::number: {
      const double min = s.key == "smooth_particles" ? 0 : s.min;
      if (!std::isfinite(max)) return fmt::format("a finite number {} {}{}", s.min_open ? ">" : "≥", number_text(min), zero);
      if (s.min_open) return fmt::format("a number > {} and ≤ {}{}", number_text(min), number_text(max), zero);
      return fmt::format("a number from {} to {}{}", number_text(min), number_text(max), zero);
    }
    case ParamType::integer:
      if (s.key == "threads")  // the range depends on the machine: the table says the rule
        return fmt::format("a whole number from 0 to {:g} per CPU{}", kThreadsPerCpu, zero);
      return fmt::format("a whole number from {} to {:.0f}{}", number_text(s.min), max, zero);
    case ParamType::flag: return "true or false";
    case ParamType::choice: {
      std::string list;
      for (std::size_t i = 0; i < s.choices.size(); ++i)
        list += fmt::format("{}{}", i == 0 ? "" : (i + 1 == s.choices.size() ? " or " : ", "), s.choices[i]);
      return "one of " + list;
    }
    case ParamType::numbers: return fmt::format("{} numbers separated by commas (xmin,ymin,zmin,xmax,ymax,zmax)", s.count);
    case ParamType::names: return "names separated by commas";
  }
  return "";
}

json get_parameter(const Params& params, const ParamSpec& spec) { return entry_of(spec).get(params); }

void set_parameter(Params& params, const ParamSpec& spec, const json& value, std::string_view written) {
  const Entry& e = entry_of(spec);
  const std::string key(spec.key);
  const std::string as_written = written.empty() ? shown(value) : std::string(written);
  const auto refuse = [&](const std::string& expectation) { throw InvalidParameter(key, as_written, expectation); };
  switch (spec.type) {
    case ParamType::number: {
      if (!value.is_number()) refuse("expected " + accepted_values(spec));
      const double v = value.get<double>();
      const bool special = spec.key == "smooth_particles" && v == -1;
      if (!special && (!in_range(spec, v) || (spec.key == "smooth_particles" && v < 0)))
        refuse(must_be(spec));
      e.set(params, v);
      return;
    }
    case ParamType::integer: {
      // 40.0 (a float that holds a whole number, as some front ends send) is accepted; 40.5 is not.
      double v = 0;
      if (value.is_number_unsigned()) v = double(value.get<uint64_t>());
      else if (value.is_number_integer()) v = double(value.get<int64_t>());
      else if (value.is_number_float() && value.get<double>() == std::floor(value.get<double>())) v = value.get<double>();
      else refuse("expected " + accepted_values(spec));
      if (!in_range(spec, v)) refuse(must_be(spec));
      e.set(params, json(int(v)));
      return;
    }
    case ParamType::flag:
      if (!value.is_boolean()) refuse("expected true or false");
      e.set(params, value);
      return;
    case ParamType::choice:
      if (!value.is_string()) refuse("expected " + accepted_values(spec));
      e.set(params, value);  // the parsers name the accepted values (and what replaced a former one)
      return;
    case ParamType::numbers: e.set(params, json(numbers_of(spec, value, written))); return;
    case ParamType::names: {
      std::vector<std::string> names;
      if (value.is_string()) {
        const json parsed = parse_parameter_text(spec, value.get<std::string>());
        names = parsed.get<std::vector<std::string>>();
      } else if (value.is_array()) {
        for (const json& item : value) {
          if (!item.is_string()) refuse("expected an array of attribute names");
          names.push_back(item.get<std::string>());
        }
      } else {
        refuse("expected an array of attribute names");
      }
      e.set(params, json(names));
      return;
    }
  }
}

json parse_parameter_text(const ParamSpec& spec, const std::string& text) {
  const std::string key(spec.key);
  const auto number = [&](std::string_view item) -> double {
    const std::size_t a = item.find_first_not_of(" \t"), b = item.find_last_not_of(" \t");
    const std::string_view trimmed = a == std::string_view::npos ? std::string_view() : item.substr(a, b - a + 1);
    double v = 0;
    const auto [end, ec] = std::from_chars(trimmed.data(), trimmed.data() + trimmed.size(), v);
    if (trimmed.empty() || end != trimmed.data() + trimmed.size() || ec == std::errc::invalid_argument)
      throw InvalidParameter(key, text, "expected " + accepted_values(spec));
    if (ec == std::errc::result_out_of_range || !std::isfinite(v))
      throw InvalidParameter(key, text, must_be(spec));
    return v;
  };
  switch (spec.type) {
    case ParamType::number: {
      const double v = number(text);
      const bool derive = spec.key == "smooth_particles" && v == -1;
      if (!derive && (!in_range(spec, v) || (spec.key == "smooth_particles" && v < 0)))
        throw InvalidParameter(key, text, must_be(spec));
      return v;
    }
    case ParamType::integer: {
      const double v = number(text);
      if (v != std::floor(v)) throw InvalidParameter(key, text, "expected " + accepted_values(spec));
      if (!in_range(spec, v)) throw InvalidParameter(key, text, must_be(spec));
      return int64_t(v);
    }
    case ParamType::flag:
      if (text == "true" || text == "1" || text == "on" || text == "yes") return true;
      if (text == "false" || text == "0" || text == "off" || text == "no") return false;
      throw InvalidParameter(key, text, "expected true or false");
    case ParamType::choice: return text;
    case ParamType::numbers: {
      std::vector<double> out;
      std::size_t at = 0;
      for (;;) {
        const std::size_t comma = std::min(text.find(',', at), text.size());
        out.push_back(number(std::string_view(text).substr(at, comma - at)));
        if (comma == text.size()) break;
        at = comma + 1;
      }
      if (out.size() != spec.count) throw InvalidParameter(key, text, "expected " + accepted_values(spec));
      return out;
    }
    case ParamType::names: {
      std::vector<std::string> out;
      std::size_t at = 0;
      while (at <= text.size()) {
        const std::size_t comma = std::min(text.find(',', at), text.size());
        if (comma > at) out.push_back(text.substr(at, comma - at));
        at = comma + 1;
      }
      return out;
    }
  }
  return nullptr;
}

namespace {

/// A box as xmin, ymin, zmin, xmax, ymax, zmax (or empty: none).
void check_box(const char* key, const std::vector<double>& box) {
  if (box.empty()) return;
  const std::string written = fmt::format("{:g}", fmt::join(box, ","));
  if (box.size() != 6) throw InvalidParameter(key, written, fmt::format("{} numbers given, expected 6 (xmin,ymin,zmin,xmax,ymax,zmax)", box.size()));
  for (std::size_t c = 0; c < 3; ++c)
    if (!std::isfinite(box[c]) || !std::isfinite(box[c + 3]) || !(box[c] < box[c + 3]))
      throw InvalidParameter(key, written, fmt::format("{0}min must be below {0}max, both finite; found {1:g} and {2:g}",
                                                       "xyz"[c], box[c], box[c + 3]));
}

}  // namespace

void Params::validate() const {
  for (const ParamSpec& spec : specs()) {
    if (spec.control || (spec.type != ParamType::number && spec.type != ParamType::integer)) continue;
    const json value = get_parameter(*this, spec);
    const double v = value.get<double>();
    const bool derive = spec.key == "smooth_particles" && v == -1;
    if (!derive && (!in_range(spec, v) || (spec.key == "smooth_particles" && v < 0)))
      throw InvalidParameter(std::string(spec.key), spec.type == ParamType::integer ? value.dump() : number_text(v),
                             must_be(spec));
  }
  if (r_inner > 0 && r_outer > 0 && !(r_inner < r_outer))
    throw InvalidParameter("r_inner", number_text(r_inner), fmt::format("must be smaller than {} ({:g})", spelled("r_outer"), r_outer));
  if (voxel_size > 0 && r_outer > 0 && voxel_size > 2 * r_outer)
    throw InvalidParameter("voxel_size", number_text(voxel_size),
                           fmt::format("must be at most 2·r_outer ({:g}); the surface would not be resolved", 2 * r_outer));
  check_box("particle_box", particle_box);
  check_box("clip_box", clip_box);
  if (clip_cap && clip_box.empty())
    throw InvalidParameter(fmt::format("{}: there is no {} to cap (give it, or drop {})", spelled("clip_cap"),
                                       spelled("clip_box"), spelled("clip_cap")));
  if (iso != 0 && field == FieldMethod::distance)
    throw InvalidParameter("iso", number_text(iso),
                           fmt::format("applies to the metaball, sph, zhu-bridson and anisotropic fields; the distance "
                                       "field's level is r_outer (give {} too)", spelled_setting("field", "metaball")));
}

json parameter_table_json() {
  static const char* kTypes[] = {"number", "integer", "flag", "choice", "numbers", "names"};
  const Params defaults;
  json out = json::array();
  for (const ParamSpec& s : specs()) {
    json j = {{"key", s.key}, {"option", s.option}, {"type", kTypes[int(s.type)]}, {"group", s.group},
              {"help", s.help}, {"accepts", accepted_values(s)}};
    if (!s.control) j["default"] = get_parameter(defaults, s);
    if (s.type == ParamType::number || s.type == ParamType::integer) {
      j["min"] = s.min;
      j["min_open"] = s.min_open;
      const double max = parameter_max(s);
      j["max"] = std::isfinite(max) ? json(max) : json(nullptr);
    }
    if (!s.zero.empty()) j["zero"] = s.zero;
    if (!s.unit.empty()) j["unit"] = s.unit;
    if (!s.choices.empty()) j["choices"] = s.choices;
    if (s.count) j["count"] = s.count;
    if (s.control) j["control"] = true;
    // The value each preset gives the parameter, where it differs from the default.
    json presets = json::object();
    for (const std::string& name : preset_names()) {
      Params preset;
      apply_preset(preset, name);
      if (!s.control && get_parameter(preset, s) != j["default"]) presets[name] = get_parameter(preset, s);
    }
    if (!presets.empty()) j["presets"] = std::move(presets);
    out.push_back(std::move(j));
  }
  return out;
}

}  // namespace meniscus
