// meniscus — the Python extension `meniscus._core` (pybind11). The public Python API is the
// package around it (python/meniscus/__init__.py); this file only converts between NumPy and
// the library's types and maps the library's exceptions onto Python's.
//
// Ownership: every array handed to Python shares memory with a C++ result (mesh or particle
// set) that was moved into a heap object owned by a capsule; the capsule is the base of every
// array of that result, so nothing is copied and the result lives as long as any of its arrays.
// Inputs are read in place when they are in the library's layout (C-ordered float32: xyz triples,
// attribute rows), whatever protocol offers them, and converted once otherwise (InputArrays).
//
// Threads: the GIL is released while the library reads, writes or reconstructs; it is taken
// back only at stage boundaries to call the progress callback and check for Ctrl-C.
//
// Exceptions: InvalidParameter and InputError → ValueError, FormatError → meniscus.FormatError (a
// ValueError with .file and .location), IoError → OSError, ResourceError → MemoryError; the
// messages are the library's what(), naming parameters as Python keywords (messages.hpp).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "meniscus/config.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/resources.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/parameters.hpp"
#include "meniscus/reconstruct.hpp"
#include "meniscus/temporal.hpp"

namespace py = pybind11;

namespace {

static_assert(sizeof(meniscus::Vec3f) == 3 * sizeof(float), "Vec3f arrays must be xyz triples");
static_assert(sizeof(meniscus::Triangle) == 3 * sizeof(uint32_t), "Triangle arrays must be index triples");

// --- C++ → NumPy, without copies ----------------------------------------------------------------

/// Moves `value` to the heap and returns it with the capsule that deletes it.
template <class T>
std::pair<T*, py::capsule> own(T&& value) {
  auto owned = std::make_unique<T>(std::move(value));
  py::capsule capsule(owned.get(), [](void* p) { delete static_cast<T*>(p); });
  return {owned.release(), std::move(capsule)};
}

/// An n × components array (n when components == 1) over `data`, kept alive by `owner`.
template <class T>
py::array view(const T* data, std::size_t n, int components, const py::capsule& owner) {
  std::vector<py::ssize_t> shape{py::ssize_t(n)};
  if (components != 1) shape.push_back(components);
  // An empty vector may have no storage: NumPy then allocates its own (empty) array.
  if (n == 0) return py::array_t<T>(shape);
  return py::array_t<T>(shape, data, owner);
}

/// Attributes as name → array. Integer attributes (ids, flags: stored as float by the library)
/// come back as int32, which is a copy; float attributes are views.
py::dict attributes_to_python(const std::vector<meniscus::Attribute>& attributes, const py::capsule& owner) {
  py::dict out;
  for (const meniscus::Attribute& a : attributes) {
    py::array values = view(a.values.data(), a.size(), a.components, owner);
    if (a.integer) values = values.attr("astype")("int32");
    out[py::str(a.name)] = values;
  }
  return out;
}

py::dict mesh_to_python(meniscus::TriangleMesh&& moved) {
  auto [mesh, owner] = own(std::move(moved));
  py::dict out;
  out["vertices"] = view(reinterpret_cast<const float*>(mesh->vertices.data()), mesh->vertices.size(), 3, owner);
  out["triangles"] =
      view(reinterpret_cast<const uint32_t*>(mesh->triangles.data()), mesh->triangles.size(), 3, owner);
  out["normals"] = view(reinterpret_cast<const float*>(mesh->normals.data()), mesh->normals.size(), 3, owner);
  out["attributes"] = attributes_to_python(mesh->attributes, owner);
  return out;
}

// --- Python arrays → C++ (in place, or one conversion into the library's layout) -----------------

std::string shape_string(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

/// DLPack's device types (dlpack.h): the host's memory, and the CUDA device's kinds.
constexpr int kDLCPU = 1, kDLCUDAHost = 3;

/// `object` as a NumPy array over its own memory, without a copy, whatever protocol it offers: a
/// NumPy array or memory map, the buffer protocol (memoryview, array.array), __array_interface__,
/// or __dlpack__ (PyTorch, JAX, CuPy … tensors on the host). An array on a CUDA device (its
/// __dlpack_device__ says so, or it offers only __cuda_array_interface__) is refused by name
/// (TypeError): the frame's checks and estimates run on the host.
py::array host_array(const py::handle& object, const std::string& what) {
  if (py::isinstance<py::array>(object)) return py::reinterpret_borrow<py::array>(object);
  if (py::hasattr(object, "__dlpack_device__") && py::hasattr(object, "__dlpack__")) {
    const py::tuple device = object.attr("__dlpack_device__")();
    const int type = device[0].cast<int>();
    if (type != kDLCPU && type != kDLCUDAHost)
      throw py::type_error(fmt::format("{} lives on a device (DLPack device type {}, id {}), not in the host's memory: "
                                       "meniscus reads particles on the host (copy them there first, e.g. "
                                       "tensor.cpu() or array.numpy())",
                                       what, type, std::string(py::str(device[1]))));
    return py::module_::import("numpy").attr("from_dlpack")(object);
  }
  if (py::hasattr(object, "__cuda_array_interface__") && !py::hasattr(object, "__array_interface__"))
    throw py::type_error(fmt::format("{} lives on a CUDA device (__cuda_array_interface__): meniscus reads particles "
                                     "on the host (copy them there first, e.g. array.numpy() or cupy.asnumpy(array))",
                                     what));
  const py::array a = py::array::ensure(object);
  if (!a) throw py::type_error(fmt::format("{} must be an array of numbers", what));
  return a;
}

/// `object` as a NumPy array as it is (host_array: no copy), which must hold numbers: a float or
/// integer dtype. Booleans, strings, objects and complex numbers are refused (TypeError naming the
/// argument) rather than converted.
py::array numeric_array(const py::handle& object, const std::string& what) {
  const py::array a = host_array(object, what);
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    throw py::type_error(fmt::format("{} must hold numbers (float or integer), got dtype {}", what,
                                     std::string(py::str(a.dtype()))));
  return a;
}

/// Refuses (ResourceError → MemoryError) input whose copies into the library's layout would
/// take more than `limit` bytes (memory_limit of max_memory_gb), before anything is copied.
void check_input_bytes(double bytes, const meniscus::Grant& limit, const std::string& what) {
  if (bytes > limit.amount)
    throw meniscus::ResourceError(fmt::format("{}: copying it into the library's layout would take {}, more than the {} "
                                              "allowed ({})",
                                              what, meniscus::human_bytes(bytes), meniscus::human_bytes(limit.amount),
                                              limit.source));
}

/// Whether `a` (float32) lies in memory as the library reads it: rows of `columns` floats one
/// after another (a one-row array whatever its stride), at a float's alignment.
bool float_rows_in_place(const py::array& a, py::ssize_t columns) {
  if (a.dtype().kind() != 'f' || a.itemsize() != sizeof(float)) return false;
  if (!a.dtype().attr("isnative").cast<bool>()) return false;  // a big-endian view
  if (reinterpret_cast<std::uintptr_t>(a.data()) % alignof(float) != 0) return false;
  const bool rows = a.shape(0) <= 1 || a.strides(0) == py::ssize_t(sizeof(float)) * columns;
  const bool cols = a.ndim() == 1 || a.shape(1) <= 1 || a.strides(1) == py::ssize_t(sizeof(float));
  return rows && cols;
}

/// The input arrays of a call as the library reads them (ParticlesView): in place where their
/// layout is the library's (float32 rows, C order), converted once into these buffers otherwise
/// (float64, other strides, integers). A Reconstructor keeps its buffers from call to call, so a
/// converted input of the same size or smaller allocates nothing.
struct InputArrays {
  std::vector<meniscus::Vec3f> positions;  // converted positions (empty: read in place)
  std::vector<std::vector<float>> attribute_values;  // converted attributes, one buffer each
  std::vector<std::string> names;
  std::size_t bytes_read_in_place = 0, bytes_copied = 0;
};

/// Reads the element at `row`, `col` of a 2-D array of T as a float.
template <class T>
float element(const char* base, py::ssize_t row_stride, py::ssize_t col_stride, std::size_t row, std::size_t col) {
  T v;
  std::memcpy(&v, base + py::ssize_t(row) * row_stride + py::ssize_t(col) * col_stride, sizeof(T));
  return float(v);
}

/// `a` (n × k, or n when k == 1 and a is 1-D) converted into `out` as n·k floats, row-major,
/// whatever its strides; native float32, float64, int32 and int64 directly, anything else
/// (booleans, other integers, float16, big-endian) through NumPy's conversion.
void convert_rows(const py::array& a, std::size_t k, float* out) {
  const std::size_t n = std::size_t(a.shape(0));
  const char* base = static_cast<const char*>(a.data());
  const py::ssize_t rs = a.strides(0), cs = a.ndim() == 2 ? a.strides(1) : 0;
  const auto run = [&](auto zero) {
    using T = decltype(zero);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t c = 0; c < k; ++c) out[i * k + c] = element<T>(base, rs, cs, i, c);
  };
  const char kind = a.dtype().kind();
  const bool native = a.dtype().attr("isnative").cast<bool>();
  if (native && kind == 'f' && a.itemsize() == 4) return run(float{});
  if (native && kind == 'f' && a.itemsize() == 8) return run(double{});
  if (native && kind == 'i' && a.itemsize() == 8) return run(std::int64_t{});
  if (native && kind == 'i' && a.itemsize() == 4) return run(std::int32_t{});
  const FloatArray f = FloatArray::ensure(a);
  if (!f) throw py::type_error("an array NumPy cannot convert to float32");
  std::memcpy(out, f.data(), n * k * sizeof(float));
}

/// The N × 3 positions `object` as xyz triples: in place when they are C-ordered float32 rows,
/// else converted once into `staging.positions` (refused before any copy when it would pass
/// `limit`). `keep` holds the NumPy arrays read in place for the length of the call.
std::span<const meniscus::Vec3f> positions_from_python(const py::handle& object, const char* what,
                                                       const meniscus::Grant& limit, InputArrays& staging,
                                                       std::vector<py::object>& keep) {
  const py::array a = numeric_array(object, what);
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(fmt::format("{} must be an N×3 array, got shape {}", what, shape_string(a)));
  const std::size_t n = std::size_t(a.shape(0));
  const meniscus::Vec3f* xyz = nullptr;
  if (float_rows_in_place(a, 3)) {
    keep.push_back(a);
    staging.bytes_read_in_place += n * sizeof(meniscus::Vec3f);
    xyz = n == 0 ? nullptr : static_cast<const meniscus::Vec3f*>(a.data());
  } else {
    check_input_bytes(double(n) * sizeof(meniscus::Vec3f), limit, what);
    staging.positions.resize(n);
    convert_rows(a, 3, reinterpret_cast<float*>(staging.positions.data()));
    staging.bytes_copied += n * sizeof(meniscus::Vec3f);
    xyz = staging.positions.data();
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(xyz[i].x) || !std::isfinite(xyz[i].y) || !std::isfinite(xyz[i].z))
      throw py::value_error(fmt::format("{}[{}] is not finite: ({}, {}, {})", what, i, xyz[i].x, xyz[i].y, xyz[i].z));
  return {xyz, n};
}

/// name → (n,) or (n, k) arrays as the library's attribute views: in place when float32 rows,
/// converted once into `staging` otherwise; integer and boolean arrays are flagged `integer` so
/// that writers restore the type.
std::vector<meniscus::AttributeView> attribute_views_from_python(const py::handle& object, std::size_t n,
                                                                 const char* what, const meniscus::Grant& limit,
                                                                 InputArrays& staging, std::vector<py::object>& keep) {
  std::vector<meniscus::AttributeView> out;
  if (object.is_none()) return out;
  if (!py::isinstance<py::dict>(object)) throw py::type_error(fmt::format("{} must be a dict of arrays", what));
  const auto dict = py::reinterpret_borrow<py::dict>(object);
  // Names first, so that the views' names point at strings that stay where they are.
  staging.names.clear();
  staging.names.reserve(dict.size());
  for (const auto& item : dict) staging.names.push_back(py::str(item.first));
  staging.attribute_values.resize(std::max(staging.attribute_values.size(), dict.size()));
  std::size_t index = 0;
  for (const auto& item : dict) {
    const std::string& name = staging.names[index];
    const std::string label = fmt::format("{} '{}'", what, name);
    const py::array a = host_array(item.second, label);
    const char kind = a.dtype().kind();
    if (kind != 'f' && kind != 'i' && kind != 'u' && kind != 'b')  // flags may be booleans
      throw py::type_error(fmt::format("{} must hold numbers, got dtype {}", label, std::string(py::str(a.dtype()))));
    if (a.ndim() < 1 || a.ndim() > 2 || std::size_t(a.shape(0)) != n || (a.ndim() == 2 && a.shape(1) < 1))
      throw py::value_error(fmt::format("{} must have shape ({},) or ({}, k), got {}", label, n, n, shape_string(a)));
    const int components = a.ndim() == 2 ? int(a.shape(1)) : 1;
    const std::size_t count = n * std::size_t(components);
    const bool integer = kind == 'i' || kind == 'u' || kind == 'b';
    std::span<const float> values;
    if (float_rows_in_place(a, components)) {
      keep.push_back(a);
      staging.bytes_read_in_place += count * sizeof(float);
      values = {count == 0 ? nullptr : static_cast<const float*>(a.data()), count};
    } else {
      check_input_bytes(double(count) * sizeof(float), limit, label);
      std::vector<float>& buffer = staging.attribute_values[index];
      buffer.resize(count);
      if (count > 0) convert_rows(a, std::size_t(components), buffer.data());
      staging.bytes_copied += count * sizeof(float);
      values = buffer;
    }
    out.emplace_back(name, components, integer, values);
    ++index;
  }
  return out;
}

/// An N × 3 array-like as owned xyz triples (write_mesh, estimate_spacing): positions_from_python
/// and a copy.
std::vector<meniscus::Vec3f> vec3_from_python(const py::handle& object, const char* what, const meniscus::Grant& limit) {
  InputArrays staging;
  std::vector<py::object> keep;
  const std::span<const meniscus::Vec3f> xyz = positions_from_python(object, what, limit, staging, keep);
  if (!staging.positions.empty()) return std::move(staging.positions);
  return {xyz.begin(), xyz.end()};
}

/// name → (n,) or (n, k) arrays as owned library attributes (write_mesh): the views and a copy.
std::vector<meniscus::Attribute> attributes_from_python(const py::handle& object, std::size_t n, const char* what,
                                                        const meniscus::Grant& limit) {
  InputArrays staging;
  std::vector<py::object> keep;
  std::vector<meniscus::Attribute> out;
  for (const meniscus::AttributeView& view : attribute_views_from_python(object, n, what, limit, staging, keep))
    out.push_back(view.copy());
  return out;
}

// --- keyword arguments → JSON parameters ---------------------------------------------------------

nlohmann::json json_from_python(const py::handle& value, const std::string& key) {
  const py::module_ numpy = py::module_::import("numpy");
  if (py::isinstance(value, numpy.attr("generic"))) return json_from_python(value.attr("item")(), key);
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>();
  if (py::isinstance<py::int_>(value)) {
    const long long v = PyLong_AsLongLong(value.ptr());
    if (v == -1 && PyErr_Occurred()) {
      PyErr_Clear();
      throw py::value_error(fmt::format("{} = {}: out of range", key, std::string(py::str(value))));
    }
    return v;
  }
  if (py::isinstance<py::float_>(value)) return value.cast<double>();
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value) || py::isinstance<py::array>(value)) {
    nlohmann::json array = nlohmann::json::array();
    for (const py::handle item : value) array.push_back(json_from_python(item, key));
    return array;
  }
  throw py::type_error(fmt::format("parameter '{}': cannot use a value of type {}", key,
                                   std::string(py::str(value.get_type().attr("__name__")))));
}

/// The keyword arguments of reconstruct() as the parameters of `meniscus::params_from_json`
/// (the keys of config.hpp; None means "not given").
meniscus::Params params_from_python(const py::dict& kwargs) {
  nlohmann::json object = nlohmann::json::object();
  for (const auto& [key, value] : kwargs) {
    if (value.is_none()) continue;
    const std::string name = py::str(key);
    object[name] = json_from_python(value, name);
  }
  return meniscus::params_from_json(object);
}

// --- entry points ----------------------------------------------------------------------------------

/// Thrown through the pipeline to stop it when the progress callback raised or Ctrl-C was hit;
/// the Python error itself waits in `pending` and is raised once the GIL is back.
struct CallbackRaised {};

/// Runs `surface` on the particles with the progress callback (None: only Ctrl-C is checked) and
/// the GIL released; returns the mesh's arrays (no copies), its stats as JSON text and the input
/// bytes `staging` read in place and copied.
template <class Surface>
py::dict surface_with_progress(Surface&& surface, const meniscus::ParticlesView& particles,
                               const InputArrays& staging, const py::object& progress) {
  std::optional<py::error_already_set> pending;
  const meniscus::ProgressFn on_progress = [&](std::string_view stage, double fraction) {
    py::gil_scoped_acquire gil;
    try {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (!progress.is_none()) progress(py::str(stage.data(), stage.size()), fraction);
    } catch (py::error_already_set& e) {
      pending.emplace(std::move(e));
      throw CallbackRaised{};
    }
  };
  meniscus::Result result;
  try {
    py::gil_scoped_release released;
    result = surface(particles, on_progress);
  } catch (const CallbackRaised&) {
    throw std::move(*pending);
  }
  std::string stats = meniscus::stats_to_json(result);
  py::dict out = mesh_to_python(std::move(result.mesh));
  out["stats"] = std::move(stats);
  out["bytes_read_in_place"] = staging.bytes_read_in_place;
  out["bytes_copied"] = staging.bytes_copied;
  return out;
}

/// The particles of a call as the library reads them (in place where it can, InputArrays).
meniscus::ParticlesView particles_view(const py::handle& positions, const py::handle& attributes,
                                       const meniscus::Grant& limit, InputArrays& staging,
                                       std::vector<py::object>& keep) {
  staging.bytes_read_in_place = staging.bytes_copied = 0;
  meniscus::ParticlesView view;
  view.positions = positions_from_python(positions, "positions", limit, staging, keep);
  view.attributes = attribute_views_from_python(attributes, view.size(), "particle attribute", limit, staging, keep);
  return view;
}

py::dict reconstruct(const py::handle& positions, const py::handle& attributes, const py::dict& kwargs,
                     const py::object& progress) {
  const meniscus::Params params = params_from_python(kwargs);
  InputArrays staging;
  std::vector<py::object> keep;
  const meniscus::ParticlesView particles =
      particles_view(positions, attributes, meniscus::memory_limit(params.max_memory_gb), staging, keep);
  return surface_with_progress(
      [&](const meniscus::ParticlesView& view, const meniscus::ProgressFn& on_progress) {
        return meniscus::reconstruct(view, params, on_progress);
      },
      particles, staging, progress);
}

/// meniscus::Reconstructor with the buffers its converted inputs go through, kept between calls.
/// Calls are refused while one runs (the flag is read and set with the GIL held), so that a second
/// thread never writes the buffers a running call reads.
class PyReconstructor {
 public:
  explicit PyReconstructor(const py::dict& kwargs)
      : surface_(params_from_python(kwargs)), limit_(meniscus::memory_limit(surface_.params().max_memory_gb)) {}

  py::dict call(const py::handle& positions, const py::handle& attributes, const py::object& progress) {
    if (busy_)
      throw std::runtime_error("Reconstructor: it is surfacing a frame already (a call from another thread, or from "
                               "its own progress callback); make one Reconstructor per thread");
    busy_ = true;
    struct Idle {
      bool& busy;
      ~Idle() { busy = false; }
    } idle{busy_};
    std::vector<py::object> keep;
    const meniscus::ParticlesView particles = particles_view(positions, attributes, limit_, staging_, keep);
    return surface_with_progress(
        [&](const meniscus::ParticlesView& view, const meniscus::ProgressFn& on_progress) {
          return surface_(view, on_progress);
        },
        particles, staging_, progress);
  }

  std::size_t frames() const { return surface_.frames(); }

 private:
  meniscus::Reconstructor surface_;
  meniscus::Grant limit_;
  InputArrays staging_;
  bool busy_ = false;
};

py::tuple read_particles(const std::string& path, const std::vector<std::string>& columns, bool drop_invalid,
                         double max_memory_gb) {
  meniscus::ReadOptions options;
  options.columns = columns;
  options.drop_invalid = drop_invalid;
  options.max_memory_gb = max_memory_gb;
  meniscus::ReadReport report;
  meniscus::ParticleSet read;
  {
    py::gil_scoped_release released;
    read = meniscus::read_particles(path, options, &report);
  }
  auto [particles, owner] = own(std::move(read));
  py::array positions =
      view(reinterpret_cast<const float*>(particles->positions.data()), particles->positions.size(), 3, owner);
  return py::make_tuple(positions, attributes_to_python(particles->attributes, owner), report.format,
                        report.dropped_invalid);
}

py::dict read_mesh(const std::string& path) {
  meniscus::TriangleMesh mesh;
  {
    py::gil_scoped_release released;
    mesh = meniscus::read_mesh(path);
  }
  return mesh_to_python(std::move(mesh));
}

void write_mesh(const std::string& path, const py::handle& vertices, const py::handle& triangles,
                const py::handle& normals, const py::handle& attributes) {
  meniscus::TriangleMesh mesh;
  const meniscus::Grant limit = meniscus::memory_limit(0);
  mesh.vertices = vec3_from_python(vertices, "vertices", limit);
  if (!normals.is_none()) mesh.normals = vec3_from_python(normals, "normals", limit);
  mesh.attributes = attributes_from_python(attributes, mesh.vertices.size(), "mesh attribute", limit);

  const py::array indices = py::array::ensure(triangles);
  if (!indices || (indices.dtype().kind() != 'i' && indices.dtype().kind() != 'u'))
    throw py::type_error("triangles must be a T×3 array of integer vertex indices");
  if (indices.ndim() != 2 || indices.shape(1) != 3)
    throw py::value_error(fmt::format("triangles must be a T×3 array, got shape {}", shape_string(indices)));
  using IndexArray = py::array_t<long long, py::array::c_style | py::array::forcecast>;
  const IndexArray wide = IndexArray::ensure(indices);
  mesh.triangles.resize(std::size_t(indices.shape(0)));
  const long long* index = wide.data();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::size_t c = 0; c < 3; ++c) {
      const long long v = index[3 * t + c];
      if (v < 0 || std::size_t(v) >= mesh.vertices.size())
        throw py::value_error(fmt::format("triangle {} refers to vertex {}, but the mesh has {} vertices", t, v,
                                          mesh.vertices.size()));
      mesh.triangles[t][c] = uint32_t(v);
    }

  py::gil_scoped_release released;
  meniscus::write_mesh(path, mesh);
}

double estimate_spacing(const py::handle& positions) {
  meniscus::ParticleSet particles;
  particles.positions = vec3_from_python(positions, "positions", meniscus::memory_limit(0));
  py::gil_scoped_release released;
  return meniscus::estimate_spacing(particles);
}

/// Frame t's positions smoothed in time with frames t − 1 and t + 1 (meniscus/temporal.hpp); each
/// frame is its N × 3 positions and its N ids. -> (positions float32 N×3, report dict)
py::tuple temporal_smoothing(const py::handle& previous, const py::handle& previous_ids, const py::handle& current,
                             const py::handle& current_ids, const py::handle& next, const py::handle& next_ids,
                             double weight, double limit) {
  const meniscus::Grant memory = meniscus::memory_limit(0);
  InputArrays staging[3];
  std::vector<py::object> keep;
  meniscus::ParticlesView frames[3];
  const std::pair<const py::handle*, const py::handle*> given[3] = {
      {&previous, &previous_ids}, {&current, &current_ids}, {&next, &next_ids}};
  const char* names[3][2] = {{"previous", "previous_ids"}, {"positions", "ids"}, {"next", "next_ids"}};
  for (int k = 0; k < 3; ++k) {
    frames[k].positions = positions_from_python(*given[k].first, names[k][0], memory, staging[k], keep);
    const py::array id_array = numeric_array(*given[k].second, names[k][1]);
    if (id_array.ndim() != 1 || std::size_t(id_array.shape(0)) != frames[k].size())
      throw py::value_error(fmt::format("{} must have shape ({},), got {}", names[k][1], frames[k].size(),
                                        shape_string(id_array)));
    py::dict ids;
    ids[meniscus::kParticleIdAttribute] = id_array;
    frames[k].attributes =
        attribute_views_from_python(ids, frames[k].size(), names[k][1], memory, staging[k], keep);
  }
  meniscus::TemporalReport report;
  std::vector<meniscus::Vec3f> smoothed;
  {
    py::gil_scoped_release released;
    smoothed = meniscus::temporal_smoothing(frames[0], frames[1], frames[2], weight, limit, &report);
  }
  auto [xyz, owner] = own(std::move(smoothed));  // the result's own memory, as a mesh's arrays are
  const py::array positions = view(reinterpret_cast<const float*>(xyz->data()), xyz->size(), 3, owner);
  py::dict r;
  r["applied"] = report.applied;
  r["skipped"] = report.skipped;
  r["matched"] = report.matched;
  r["clamped"] = report.clamped;
  r["mean_shift"] = report.mean_shift;
  r["max_shift"] = report.max_shift;
  return py::make_tuple(positions, r);
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "meniscus: fluid particles to a smooth watertight triangle mesh (the C++ core; use the package)";
  // Messages name parameters as Python keywords: "steps_a=20001: must be …".
  meniscus::set_message_spelling(meniscus::Spelling::python);
  m.attr("__version__") = meniscus::version();

  static py::exception<meniscus::FormatError> format_error(m, "FormatError", PyExc_ValueError);
  format_error.doc() =
      "A particle or mesh file could not be parsed. The message names the file, the byte offset or "
      "line and what was expected; .file and .location hold the first two.";
  py::register_exception_translator([](std::exception_ptr thrown) {
    try {
      if (thrown) std::rethrow_exception(thrown);
    } catch (const meniscus::FormatError& e) {
      py::object error = py::reinterpret_borrow<py::object>(format_error)(e.what());
      error.attr("file") = e.file();
      error.attr("location") = e.location();
      PyErr_SetObject(format_error.ptr(), error.ptr());
    } catch (const meniscus::InvalidParameter& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const meniscus::InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const meniscus::IoError& e) {
      PyErr_SetString(PyExc_OSError, e.what());
    } catch (const meniscus::ResourceError& e) {
      PyErr_SetString(PyExc_MemoryError, e.what());
    }
  });

  m.def("reconstruct", &reconstruct, py::arg("positions"), py::arg("attributes"), py::arg("params"),
        py::arg("progress"),
        "positions N×3, attributes dict or None, params dict of config.hpp keys, progress callable or None "
        "-> dict(vertices, triangles, normals, attributes, stats JSON string)");
  py::class_<PyReconstructor>(m, "Reconstructor")
      .def(py::init<const py::dict&>(), py::arg("params"))
      .def("__call__", &PyReconstructor::call, py::arg("positions"), py::arg("attributes"), py::arg("progress"))
      .def_property_readonly("frames", &PyReconstructor::frames);
  m.def("read_particles", &read_particles, py::arg("path"), py::arg("columns"), py::arg("drop_invalid"),
        py::arg("max_memory_gb"), "-> (positions N×3 float32, attributes dict, format, dropped_invalid)");
  m.def("read_mesh", &read_mesh, py::arg("path"), "-> dict(vertices, triangles, normals, attributes)");
  m.def("write_mesh", &write_mesh, py::arg("path"), py::arg("vertices"), py::arg("triangles"), py::arg("normals"),
        py::arg("attributes"));
  m.def("estimate_spacing", &estimate_spacing, py::arg("positions"));
  m.def("temporal_smoothing", &temporal_smoothing, py::arg("previous"), py::arg("previous_ids"), py::arg("positions"),
        py::arg("ids"), py::arg("next"), py::arg("next_ids"), py::arg("weight"), py::arg("limit"),
        "three frames' positions and ids -> (frame t's positions smoothed in time, report dict)");
  m.def("preset_names", &meniscus::preset_names);
  m.def("parameter_table", [] { return meniscus::parameter_table_json().dump(); },
        "the table of parameters as JSON text: keys, types, ranges, defaults, help");
  m.def("particle_formats", &meniscus::particle_formats);
  m.def("mesh_formats", &meniscus::mesh_formats);
}
