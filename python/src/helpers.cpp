// python/src/helpers.cpp - what the binding files of prt's Python module
// share (module.h): arrays, argument checks, progress and Ctrl-C, map and
// file arguments.
#include "module.h"

#include <prt/gpu_tracer.h>
#include <prt/io.h>
#include <prt/precompute.h>
#include <prt/probes.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/wavelet.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cstdio>

namespace prt::python {

// ---- arrays --------------------------------------------------------------------

py::array_t<float> vec3s(const std::vector<glm::vec3>& v) {
  return copy(reinterpret_cast<const float*>(v.data()), {py::ssize_t(v.size()), 3});
}

std::string shape_text(const py::array& a) { return py::str(a.attr("shape")); }

// ---- array arguments (module.h) ------------------------------------------------

py::array arg_array(const py::handle& obj, const std::string& what) {
  if (obj.is_none()) throw Error(what + ": expected an array, got None");
  py::object a;
  try {
    a = py::module_::import("numpy").attr("asarray")(obj);
  } catch (py::error_already_set& e) {
    throw Error(what + ": cannot be read as an array (" + std::string(py::str(e.value())) + ")");
  }
  const py::array arr = a.cast<py::array>();
  const char kind = arr.dtype().kind();
  const std::string dt = py::str(arr.dtype());
  if (kind == 'b') throw Error(what + ": an array of booleans (dtype bool); numbers are expected");
  if (kind == 'c')
    throw Error(what + ": an array of complex numbers (dtype " + dt +
                "); real numbers are expected (pass .real if that is what is meant)");
  if (kind == 'O')
    throw Error(what + ": an array of Python objects (dtype object: ragged lists, or elements that are not "
                       "numbers); a rectangular array of numbers is expected");
  if (kind != 'i' && kind != 'u' && kind != 'f')
    throw Error(what + ": dtype " + dt + " is not a number type; an array of numbers is expected");
  return arr;
}

std::string index_text(std::size_t k, const py::array& a) {
  std::vector<std::size_t> idx(std::size_t(a.ndim()));
  for (py::ssize_t d = a.ndim() - 1; d >= 0; --d) {
    const auto n = std::size_t(a.shape(d));
    idx[std::size_t(d)] = n ? k % n : 0;
    k = n ? k / n : 0;
  }
  std::string s = "[";
  for (std::size_t d = 0; d < idx.size(); ++d) s += (d ? ", " : "") + std::to_string(idx[d]);
  return s + "]";
}

std::string number_text(double x) { return py::str(py::float_(x)); }

UArray index_array(const py::handle& obj, const std::string& what) {
  const py::array raw = arg_array(obj, what);
  DArray d = DArray::ensure(raw);  // exact for every uint32 (and reports what is out of range)
  if (raw.dtype().kind() != 'f') {
    // Integers beyond 2^53 would round in double: check them as integers.
    py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> i =
        raw.dtype().kind() == 'u' && raw.dtype().itemsize() == 8
            ? py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>()
            : py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(raw);
    if (i) {
      for (std::size_t k = 0; k < std::size_t(i.size()); ++k)
        if (i.data()[k] < 0 || i.data()[k] > std::int64_t(std::numeric_limits<std::uint32_t>::max()))
          throw Error(what + ": element " + index_text(k, i) + " is " + std::to_string(i.data()[k]) +
                      "; indices must be in [0, 2^32)");
    }
  }
  for (std::size_t k = 0; k < std::size_t(d.size()); ++k) {
    const double x = d.data()[k];
    if (!std::isfinite(x) || x != std::floor(x))
      throw Error(what + ": element " + index_text(k, d) + " is " + number_text(x) +
                  "; indices must be whole numbers (refused rather than truncated)");
    if (x < 0 || x > double(std::numeric_limits<std::uint32_t>::max()))
      throw Error(what + ": element " + index_text(k, d) + " is " + number_text(x) + "; indices must be in [0, 2^32)");
  }
  return UArray::ensure(d);
}

int int_arg(const py::handle& obj, const std::string& what) {
  if (py::isinstance<py::bool_>(obj) || py::isinstance(obj, py::module_::import("numpy").attr("bool_")))
    throw Error(what + ": a bool (" + std::string(py::str(obj)) + "); a whole number is expected");
  if (!py::isinstance<py::int_>(obj) && !py::isinstance(obj, py::module_::import("numpy").attr("integer")))
    throw Error(what + ": expected a whole number, got " + std::string(py::str(py::type::of(obj).attr("__name__"))) +
                " " + std::string(py::repr(obj)));
  const py::int_ i(py::reinterpret_borrow<py::object>(obj));
  const long long v = PyLong_AsLongLong(i.ptr());
  if (v == -1 && PyErr_Occurred()) {
    PyErr_Clear();
    throw Error(what + ": " + std::string(py::str(obj)) + " is out of range");
  }
  if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
    throw Error(what + ": " + std::to_string(v) + " is out of range");
  return int(v);
}

std::vector<glm::dvec3> to_coeffs(const py::handle& obj, const char* what) {
  DArray a = real_array<double>(obj, what);
  if (a.ndim() != 2 || a.shape(1) != 3 || a.shape(0) < 1)
    throw Error(std::string(what) + ": expected SH coefficients of shape (n*n, 3), got " + shape_text(a));
  std::vector<glm::dvec3> c(std::size_t(a.shape(0)));
  for (std::size_t k = 0; k < c.size(); ++k) c[k] = {a.at(k, 0), a.at(k, 1), a.at(k, 2)};
  return c;
}

glm::vec3 to_albedo(const py::handle& obj) {
  FArray a = real_array<float>(obj, "albedo");
  if (a.ndim() == 0) return glm::vec3(a.data()[0]);
  if (a.ndim() != 1 || a.shape(0) != 3)
    throw Error("albedo: expected a number or 3 numbers r, g, b, got an array of shape " + shape_text(a));
  return {a.data()[0], a.data()[1], a.data()[2]};
}

glm::dmat3 to_rotation(const py::handle& obj, const char* what) {
  DArray a = real_array<double>(obj, what);
  if (a.ndim() == 1 && a.shape(0) == 3) return prt::sh::rotation_from_euler(a.at(0), a.at(1), a.at(2));
  if (a.ndim() == 2 && a.shape(0) == 3 && a.shape(1) == 3) {
    glm::dmat3 m;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m[j][i] = a.at(i, j);
    const glm::dmat3 g = glm::transpose(m) * m;
    double off = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) off = std::max(off, std::abs(g[i][j] - (i == j ? 1.0 : 0.0)));
    if (off > kRotationTol || !(glm::determinant(m) > 0))
      throw Error(std::string(what) + ": not a rotation matrix (R^T R differs from the identity by " + number_text(off) +
                  ", determinant " + number_text(glm::determinant(m)) + "; a rotation is orthonormal with determinant 1)");
    return m;
  }
  throw Error(std::string(what) + ": expected a 3x3 rotation matrix or (yaw, pitch, roll) in degrees, got shape " +
              shape_text(a));
}

std::vector<glm::vec3> to_vec3s(const py::handle& obj, const char* what, std::optional<std::size_t> rows,
                                const char* rows_of) {
  FArray a = real_array<float>(obj, what);
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw Error(std::string(what) + ": expected an array of shape (N, 3), got " + shape_text(a));
  if (rows && std::size_t(a.shape(0)) != *rows)
    throw Error(std::string(what) + ": " + std::to_string(a.shape(0)) + " rows; expected one per " + rows_of + ", " +
                std::to_string(*rows));
  std::vector<glm::vec3> v(std::size_t(a.shape(0)));
  if (!v.empty()) std::memcpy(&v[0].x, a.data(), v.size() * sizeof(glm::vec3));
  return v;
}

// ---- progress, Ctrl-C ----------------------------------------------------------

namespace {

// SIGINT's flag while an InterruptScope has the handler (module.h).
std::atomic<bool> g_interrupted{false};
void on_sigint(int) { g_interrupted = true; }

}  // namespace

InterruptScope::InterruptScope() {
  if (PyGILState_Check() && py::module_::import("threading").attr("current_thread")().is(
                                py::module_::import("threading").attr("main_thread")())) {
    py::object handler = py::module_::import("signal").attr("getsignal")(SIGINT);
    if (!handler.is(py::module_::import("signal").attr("default_int_handler"))) return;
    g_interrupted = false;
    struct sigaction sa {};
    sa.sa_handler = on_sigint;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    installed_ = sigaction(SIGINT, &sa, &previous_) == 0;
  }
}

InterruptScope::~InterruptScope() {
  if (installed_) sigaction(SIGINT, &previous_, nullptr);
}

bool InterruptScope::interrupted() const { return installed_ && g_interrupted; }

PyProgress::PyProgress(py::object callback) {
  if (callback.is_none() || (py::isinstance<py::bool_>(callback) && !callback.cast<bool>())) return;
  if (py::isinstance<py::bool_>(callback)) {  // True: a line on sys.stderr
    callback = py::cpp_function([](std::size_t done, std::size_t total, const std::string& phase) {
      py::object err = py::module_::import("sys").attr("stderr");
      const int pct = total ? int(100.0 * double(done) / double(total)) : 100;
      err.attr("write")("\r" + phase + ": " + std::to_string(pct) + "% (" + std::to_string(done) + "/" +
                        std::to_string(total) + ")" + (done == total ? "\n" : ""));
      err.attr("flush")();
    });
  } else if (!PyCallable_Check(callback.ptr())) {
    throw Error("progress: expected None, True, False or a callable (done, total, phase)");
  }
  fn_ = std::move(callback);
}

void PyProgress::rethrow(const std::exception_ptr& e) {
  if (error_) {
    std::unique_ptr<py::error_already_set> err = std::move(error_);
    err->restore();
    throw py::error_already_set();
  }
  if (interrupts_.interrupted()) {
    PyErr_SetNone(PyExc_KeyboardInterrupt);
    throw py::error_already_set();
  }
  std::rethrow_exception(e);
}

bool PyProgress::update(std::size_t done, std::size_t total, const char* phase) {
  if (interrupts_.interrupted() || stopped_) return false;
  if (!fn_) return true;
  const int pct = total ? int(100.0 * double(done) / double(total)) : 100;
  if (phase_ == phase && (done == done_ || (done != total && pct == percent_))) return true;
  phase_ = phase;
  percent_ = pct;
  done_ = done;
  py::gil_scoped_acquire gil;
  try {
    py::object r = fn_(done, total, phase);
    if (r.ptr() == Py_False) stopped_ = true;
  } catch (py::error_already_set& e) {
    error_ = std::make_unique<py::error_already_set>(std::move(e));
    stopped_ = true;
  }
  return !stopped_;
}

// ---- options shared by several calls -------------------------------------------

std::optional<prt::AdaptiveOptions> adaptive_arg(const py::object& adaptive, double verify, bool any, int samples) {
  if (adaptive.is_none()) {
    if (verify != 0) throw Error("verify_adaptive: is for adaptive sample points; give adaptive= too");
    if (any) throw Error("adaptive_any: is for adaptive sample points; give adaptive= too");
    return std::nullopt;
  }
  if (py::isinstance<py::bool_>(adaptive) || py::isinstance(adaptive, py::module_::import("numpy").attr("bool_")))
    throw Error("adaptive: a bool (" + std::string(py::str(adaptive)) +
                "); expected None, 0 (the default tolerance for the samples) or a tolerance in (0, 1)");
  double tol = 0;
  try {
    tol = adaptive.cast<double>();
  } catch (const py::cast_error&) {
    throw Error("adaptive: expected None, 0 (the default tolerance for the samples) or a tolerance in (0, 1), got " +
                std::string(py::str(py::type::of(adaptive).attr("__name__"))) + " " + std::string(py::repr(adaptive)));
  }
  if (tol != 0 && !(tol > 0 && tol < 1))
    throw Error("adaptive: " + number_text(tol) + ": the tolerance must be in (0, 1) (0: the default for the samples)");
  const double most = prt::max_adaptive_tolerance(samples);
  if (tol > most && !any) {
    char m[32];
    std::snprintf(m, sizeof m, "%.3g", most);
    throw Error("adaptive: " + number_text(tol) + ": above " + m + ", the largest tolerance for " +
                std::to_string(samples) +
                " samples whose error stays within 1.1x the full run's (docs/PRECOMPUTE.md, \"Adaptive sample "
                "points\"); give adaptive_any=True to use it anyway");
  }
  if (!(verify >= 0 && verify <= 1))
    throw Error("verify_adaptive: " + number_text(verify) + ": a fraction in [0, 1]");
  prt::AdaptiveOptions a;  // probe fraction, probes and seed as the command's
  a.tolerance = tol;
  a.verify_fraction = verify;
  return a;
}

int threads_arg(int threads) {
  if (threads < 0 || threads > prt::kMaxThreads)
    throw Error("threads: must be 0 (every core) to " + std::to_string(prt::kMaxThreads) + ", got " +
                std::to_string(threads));
  return threads;
}

namespace {

// A limit as the command prints it ({:g}: 64, not 64.0).
std::string limit_text(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", x);
  return b;
}

}  // namespace

double exposure_arg(const py::object& exposure) {
  const DArray ev = real_array<double>(exposure, "exposure");
  if (ev.ndim() != 0) throw Error("exposure: stops (a number) or 'auto'");
  const double stops = ev.data()[0];
  if (!(std::abs(stops) <= prt::kMaxExposureStops))
    throw Error("exposure: must be a number in [-" + limit_text(prt::kMaxExposureStops) + ", " +
                limit_text(prt::kMaxExposureStops) + "] (stops) or 'auto', got " + number_text(stops));
  return stops;
}

std::optional<double> fov_arg(const py::object& fov_obj) {
  if (fov_obj.is_none()) return std::nullopt;
  const DArray f = real_array<double>(fov_obj, "fov");
  if (f.ndim() != 0) throw Error("fov: vertical degrees (a number) or None");
  const double fov = f.data()[0];
  if (!(fov >= prt::kMinFov && fov <= prt::kMaxFov))
    throw Error("fov: vertical degrees, " + limit_text(prt::kMinFov) + " to " + limit_text(prt::kMaxFov) + ", got " +
                number_text(fov));
  return fov;
}

void check_terms(int terms) {
  if (terms < 1 || terms > prt::wavelet::kMaxTerms)
    throw Error("terms: must be 1 to " + std::to_string(prt::wavelet::kMaxTerms) + " (K >= 6 r^2 keeps all), got " +
                std::to_string(terms));
}

glm::dvec3 diffuse_arg(const py::object& diffuse) {
  const FArray d = real_array<float>(diffuse, "diffuse");
  glm::dvec3 rho;
  if (d.ndim() == 0) rho = glm::dvec3(d.data()[0]);
  else if (d.ndim() == 1 && d.shape(0) == 3) rho = {d.data()[0], d.data()[1], d.data()[2]};
  else throw Error("diffuse: expected rho_d, a number or 3 numbers r, g, b, got shape " + shape_text(d));
  if (!prt::albedo_in_range(glm::vec3(rho)))
    throw Error("diffuse: each of r, g, b must be from 0 to 1 (an albedo), got (" + number_text(rho.x) + ", " +
                number_text(rho.y) + ", " + number_text(rho.z) + ")");
  return rho;
}

void check_not_input(const std::string& what, const std::string& out, const std::vector<NamedInput>& inputs) {
  for (const NamedInput& in : inputs)
    if (prt::same_file(out, in.path))
      throw Error(what + ": " + out + ": is the input " + in.name + (in.path == out ? "" : " (" + in.path + ")") +
                  "; prt does not write over its inputs (choose another output name)");
}

// ---- files and maps ------------------------------------------------------------

bool is_path(const py::handle& h) {
  return py::isinstance<py::str>(h) || py::isinstance(h, py::module_::import("os").attr("PathLike"));
}

std::string path_of(const py::handle& h, const std::string& what) {
  if (!is_path(h))
    throw Error(what + ": expected a file name (str or os.PathLike), got " +
                std::string(py::str(py::type::of(h).attr("__name__"))));
  const std::string p = py::str(py::module_::import("os").attr("fspath")(h));
  if (p.empty()) throw Error(what + ": expected a file name, got ''");  // as the command's path options
  return p;
}

const prt::EnvMap& map_argument(const py::object& map, prt::EnvMap& storage) {
  if (py::isinstance<prt::EnvMap>(map)) return map.cast<const prt::EnvMap&>();
  storage = is_path(map) ? prt::load_envmap(path_of(map, "map")) : map_from_array(map);
  return storage;
}

prt::EnvMap map_from_array(const py::handle& obj) {
  FArray a = real_array<float>(obj, "map");
  if (a.ndim() == 3 && a.shape(2) == 3) {
    std::vector<float> rgb(a.data(), a.data() + a.size());
    return prt::make_latlong(int(a.shape(1)), int(a.shape(0)), std::move(rgb), "<array>");
  }
  if (a.ndim() == 4 && a.shape(0) == 6 && a.shape(1) == a.shape(2) && a.shape(3) == 3) {
    std::vector<float> rgb(a.data(), a.data() + a.size());
    return prt::make_cube(int(a.shape(1)), std::move(rgb), "<array>");
  }
  throw Error("map: expected an array of shape (H, W, 3) (lat-long) or (6, N, N, 3) (cube faces), got " +
              shape_text(a));
}

std::array<int, 3> probe_dims_arg(const py::object& dims, const std::string& what) {
  const std::string rule = what + ": expected (NX, NY, NZ), three whole numbers, each 2 to " +
                           std::to_string(prt::kMaxProbeDim) + ", at most " + std::to_string(prt::kMaxProbes) +
                           " probes in all";
  std::string shown = py::repr(dims);
  if (shown.size() > 60) shown = shown.substr(0, 57) + "...";
  const std::string got = ", got " + std::string(py::str(py::type::of(dims).attr("__name__"))) + " " + shown;
  if (dims.is_none() || py::isinstance<py::str>(dims) || py::isinstance<py::bytes>(dims) ||
      !PySequence_Check(dims.ptr()))
    throw Error(rule + got);
  const Py_ssize_t n = PySequence_Size(dims.ptr());
  if (n < 0) {  // a 0-d array: a sequence without a length
    PyErr_Clear();
    throw Error(rule + got);
  }
  if (n != 3) throw Error(rule + got + " (" + std::to_string(n) + " values)");
  const py::sequence seq = py::reinterpret_borrow<py::sequence>(dims);
  std::array<int, 3> d{};
  for (std::size_t k = 0; k < 3; ++k) d[k] = int_arg(seq[k], what + "[" + std::to_string(k) + "]");
  if (const std::string p = prt::probe_dims_problem(d); !p.empty()) throw Error(what + ": " + shown + ": " + p);
  return d;
}

void light_bounce_args(prt::TransferOptions& o, bool light_bounce, double patch, double ratio, int clusters,
                       const py::object& probes) {
  o.light_bounce = light_bounce;
  o.light_bounce_patch = patch;
  o.light_bounce_ratio = ratio;
  o.light_bounce_clusters = clusters;
  if (!probes.is_none()) o.light_bounce_probes = probe_dims_arg(probes, "bounce_probes");
  const bool shaped = patch != 0.0 || ratio != prt::kLightBounceRatio || clusters != prt::kLightBounceClusters ||
                      !probes.is_none();
  if (shaped && !light_bounce)
    throw Error("bounce_patch, bounce_ratio, bounce_clusters and bounce_probes shape the light_bounce operator: give "
                "light_bounce=True too");
}

void check_device_arg(const std::string& device, prt::TransferKind kind, const std::string& material) {
  if (device != "cpu" && device != "gpu") throw Error("device: expected 'cpu' or 'gpu', got '" + device + "'");
  if (device == "cpu") return;
  // The kinds the GPU makes: the kind table's (prt/transfer_file.h, Consumer::GpuPrecompute).
  if (const prt::Support& s = prt::support(kind, prt::Consumer::GpuPrecompute); !s.works)
    throw Error("device='gpu': " + std::string(s.why));
  const auto no = [](const std::string& what) {
    throw Error("device='gpu': " + what + " (leave device='cpu')");
  };
  if (material == "subsurface") no("material='subsurface' gathers the light entering the surface from points the CPU traces");
}

std::unique_ptr<prt::PointTracer> device_tracer(const std::string& device, const prt::Mesh& mesh) {
  if (device != "gpu") return nullptr;
  return prt::make_gl_point_tracer(prt::build_flat_bvh(mesh));
}

}  // namespace prt::python
