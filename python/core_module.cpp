// meniscus — the Python extension `meniscus._core` (pybind11). The public Python API is the
// package around it (python/meniscus/__init__.py); this file only converts between NumPy and
// the library's types and maps the library's exceptions onto Python's.
//
// Ownership: every array handed to Python shares memory with a C++ result (mesh or particle
// set) that was moved into a heap object owned by a capsule; the capsule is the base of every
// array of that result, so nothing is copied and the result lives as long as any of its arrays.
// Inputs are copied once into the library's layout (float32 xyz triples).
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
#include <memory>
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

// --- NumPy → C++ (one copy into the library's layout) --------------------------------------------

std::string shape_string(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

/// `object` as a NumPy array as it is (a view of a NumPy array or a memory map, no copy), which
/// must hold numbers: a float or integer dtype. Booleans, strings, objects and complex numbers
/// are refused (TypeError naming the argument) rather than converted.
py::array numeric_array(const py::handle& object, const std::string& what) {
  const py::array a = py::array::ensure(object);
  if (!a) throw py::type_error(fmt::format("{} must be an array of numbers", what));
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

/// An N × 3 array-like as xyz triples (float64 and integer inputs are converted to float32),
/// refused before any copy when the copies would pass `limit`.
std::vector<meniscus::Vec3f> vec3_from_python(const py::handle& object, const char* what, const meniscus::Grant& limit) {
  const py::array original = numeric_array(object, what);
  if (original.ndim() != 2 || original.shape(1) != 3)
    throw py::value_error(fmt::format("{} must be an N×3 array, got shape {}", what, shape_string(original)));
  // The float32 conversion (when the array is not one already) and the triples.
  check_input_bytes(double(original.shape(0)) * 3 * (sizeof(float) + sizeof(float)), limit, what);
  const FloatArray a = FloatArray::ensure(original);
  if (!a) throw py::type_error(fmt::format("{} must be an N×3 array of numbers", what));
  std::vector<meniscus::Vec3f> out(std::size_t(a.shape(0)));
  const float* xyz = a.data();
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
  return out;
}

/// name → (n,) or (n, k) arrays as library attributes; integer and boolean arrays are flagged
/// `integer` so that writers restore the type.
std::vector<meniscus::Attribute> attributes_from_python(const py::handle& object, std::size_t n, const char* what,
                                                        const meniscus::Grant& limit) {
  std::vector<meniscus::Attribute> out;
  if (object.is_none()) return out;
  if (!py::isinstance<py::dict>(object)) throw py::type_error(fmt::format("{} must be a dict of arrays", what));
  for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(object)) {
    meniscus::Attribute a;
    a.name = py::str(key);
    const py::array original = py::array::ensure(value);
    if (!original) throw py::type_error(fmt::format("{} '{}' must be an array of numbers", what, a.name));
    const char dtype_kind = original.dtype().kind();
    if (dtype_kind != 'f' && dtype_kind != 'i' && dtype_kind != 'u' && dtype_kind != 'b')  // flags may be booleans
      throw py::type_error(fmt::format("{} '{}' must hold numbers, got dtype {}", what, a.name,
                                       std::string(py::str(original.dtype()))));
    check_input_bytes(double(original.size()) * 2 * sizeof(float), limit, fmt::format("{} '{}'", what, a.name));
    const FloatArray values = FloatArray::ensure(original);
    if (!values) throw py::type_error(fmt::format("{} '{}' must be an array of numbers", what, a.name));
    if (values.ndim() < 1 || values.ndim() > 2 || std::size_t(values.shape(0)) != n ||
        (values.ndim() == 2 && values.shape(1) < 1))
      throw py::value_error(fmt::format("{} '{}' must have shape ({},) or ({}, k), got {}", what, a.name, n, n,
                                        shape_string(values)));
    a.components = values.ndim() == 2 ? int(values.shape(1)) : 1;
    const char kind = original.dtype().kind();
    a.integer = kind == 'i' || kind == 'u' || kind == 'b';
    a.values.assign(values.data(), values.data() + values.size());
    out.push_back(std::move(a));
  }
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

py::dict reconstruct(const py::handle& positions, const py::handle& attributes, const py::dict& kwargs,
                     const py::object& progress) {
  const meniscus::Params params = params_from_python(kwargs);
  const meniscus::Grant limit = meniscus::memory_limit(params.max_memory_gb);
  meniscus::ParticleSet particles;
  particles.positions = vec3_from_python(positions, "positions", limit);
  particles.attributes = attributes_from_python(attributes, particles.size(), "particle attribute", limit);

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
    result = meniscus::reconstruct(particles, params, on_progress);
  } catch (const CallbackRaised&) {
    throw std::move(*pending);
  }
  std::string stats = meniscus::stats_to_json(result);
  py::dict out = mesh_to_python(std::move(result.mesh));
  out["stats"] = std::move(stats);
  return out;
}

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
  m.def("read_particles", &read_particles, py::arg("path"), py::arg("columns"), py::arg("drop_invalid"),
        py::arg("max_memory_gb"), "-> (positions N×3 float32, attributes dict, format, dropped_invalid)");
  m.def("read_mesh", &read_mesh, py::arg("path"), "-> dict(vertices, triangles, normals, attributes)");
  m.def("write_mesh", &write_mesh, py::arg("path"), py::arg("vertices"), py::arg("triangles"), py::arg("normals"),
        py::arg("attributes"));
  m.def("estimate_spacing", &estimate_spacing, py::arg("positions"));
  m.def("preset_names", &meniscus::preset_names);
  m.def("parameter_table", [] { return meniscus::parameter_table_json().dump(); },
        "the table of parameters as JSON text: keys, types, ranges, defaults, help");
  m.def("particle_formats", &meniscus::particle_formats);
  m.def("mesh_formats", &meniscus::mesh_formats);
}
