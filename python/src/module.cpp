// python/src/module.cpp - prt's Python module (pybind11): maps, meshes,
// transfer files and the computations of the prt command as numpy arrays.
// The top layer, like tools/prt: it only calls the libraries (docs/PYTHON.md).
//
// Arrays prt owns (a map's pixels, a mesh's vertices, a transfer's rows) are
// read-only views that keep their object alive; everything computed is a new
// array. Long computations (precompute, reference) release the GIL; their
// progress callback takes it back, and Ctrl-C or an exception raised by the
// callback stops them (the library's Progress returns false: prt/progress.h).
#include <prt/compressed_transfer.h>
#include <prt/compression_error.h>
#include <prt/deform.h>
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/file_info.h>
#include <prt/filter.h>
#include <prt/gltf.h>
#include <prt/io.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/scene.h>
#include <prt/paths.h>
#include <prt/precompute.h>
#include <prt/probe_object.h>
#include <prt/probes.h>
#include <prt/progress.h>
#include <prt/projection.h>
#include <prt/reference.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/sh.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/verify.h>
#include <prt/web_export.h>
#include <prt/vertex_csv.h>
#include <prt/wavelet.h>
#include <prt/wavelet_playback.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh_transfer.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <tbb/global_control.h>

#include <array>
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <mutex>
#include <thread>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include <pthread.h>

namespace py = pybind11;

namespace {

using prt::Error;

// ---- arrays --------------------------------------------------------------------

// A read-only numpy view of `data`, which `owner` keeps alive.
template <typename T>
py::array view(const T* data, std::vector<py::ssize_t> shape, py::handle owner) {
  if (!data) return py::array_t<T>(shape);  // empty: nothing to share
  py::array a(py::dtype::of<T>(), shape, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

template <typename T>
py::array_t<T> copy(const T* data, std::vector<py::ssize_t> shape) {
  py::array_t<T> a(shape);
  std::size_t n = 1;
  for (auto s : shape) n *= std::size_t(s);
  if (n) std::memcpy(a.mutable_data(), data, n * sizeof(T));
  return a;
}

py::array_t<float> vec3s(const std::vector<glm::vec3>& v) {
  return copy(reinterpret_cast<const float*>(v.data()), {py::ssize_t(v.size()), 3});
}

using DArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using FArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using UArray = py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast>;

std::string shape_text(const py::array& a) { return py::str(a.attr("shape")); }

// ---- array arguments (docs/PYTHON.md, "Arguments") -----------------------------
//
// Every array a caller passes goes through arg_array: whatever numpy reads as
// an array (lists, tuples, any real dtype, non-contiguous or Fortran-ordered
// arrays: read by value, in C order) is taken; complex, boolean, object,
// string and date arrays are refused, as are ragged lists; each refusal is a
// prt.Error naming the argument. Then real_array (values finite where the
// callee needs them) or index_array (whole numbers in [0, 2^32): a fraction
// is refused, not truncated) gives the typed copy, and the shape checks
// follow at the call.

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

// The [i, j, ...] position of flat element k of an array of `shape`.
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

// A real array as T (double or float), every value finite when `finite`
// (float: also within float's range, which would otherwise become inf).
template <typename T>
py::array_t<T, py::array::c_style | py::array::forcecast> real_array(const py::handle& obj, const std::string& what,
                                                                     bool finite = true) {
  const py::array raw = arg_array(obj, what);
  DArray d = DArray::ensure(raw);
  if (!d) throw Error(what + ": cannot be read as an array of numbers");
  if (finite) {
    const double* x = d.data();
    for (std::size_t k = 0; k < std::size_t(d.size()); ++k) {
      if (!std::isfinite(x[k]))
        throw Error(what + ": element " + index_text(k, d) + " is " + number_text(x[k]) + "; values must be finite");
      if (std::is_same_v<T, float> && std::abs(x[k]) > double(std::numeric_limits<float>::max()))
        throw Error(what + ": element " + index_text(k, d) + " is " + number_text(x[k]) +
                    ", beyond float32's range (values are stored as float32)");
    }
  }
  if constexpr (std::is_same_v<T, double>) {
    return d;
  } else {
    return py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(d);
  }
}

// An index array as uint32: whole numbers from 0 to 2^32 - 1; integers of
// any width, or floats that hold whole numbers (a fraction is refused).
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

// A whole-number argument: a Python or numpy integer (not a bool, not a
// float, even a whole one: a count is written as one), within int's range.
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

// (N, 3) or (3,) -> N rows; `what` names the argument in the message.
std::size_t rows_of3(const py::array& a, const char* what) {
  if (a.ndim() == 1 && a.shape(0) == 3) return 1;
  if (a.ndim() == 2 && a.shape(1) == 3) return std::size_t(a.shape(0));
  throw Error(std::string(what) + ": expected an array of shape (N, 3) or (3,), got " + shape_text(a));
}

// A read-only (N, 3) view of glm vectors (three floats each, packed).
template <typename V>
py::array view3(const std::vector<V>& v, py::handle owner) {
  using T = typename V::value_type;
  return view(v.empty() ? nullptr : reinterpret_cast<const T*>(v.data()), {py::ssize_t(v.size()), 3}, owner);
}

// Lighting coefficients (n*n, 3), float64, every one finite (a NaN would
// reach every vertex).
std::vector<glm::dvec3> to_coeffs(const py::handle& obj, const char* what) {
  DArray a = real_array<double>(obj, what);
  if (a.ndim() != 2 || a.shape(1) != 3 || a.shape(0) < 1)
    throw Error(std::string(what) + ": expected SH coefficients of shape (n*n, 3), got " + shape_text(a));
  std::vector<glm::dvec3> c(std::size_t(a.shape(0)));
  for (std::size_t k = 0; k < c.size(); ++k) c[k] = {a.at(k, 0), a.at(k, 1), a.at(k, 2)};
  return c;
}

py::array_t<double> from_coeffs(const std::vector<glm::dvec3>& c) {
  return copy(reinterpret_cast<const double*>(c.data()), {py::ssize_t(c.size()), 3});
}

int bands_of_count(std::size_t n, const char* what) {
  const int b = int(std::lround(std::sqrt(double(n))));
  if (b < 1 || std::size_t(b) * std::size_t(b) != n)
    throw Error(std::string(what) + ": " + std::to_string(n) + " coefficients is not a square number n*n");
  return b;
}

// A number, or three (r, g, b); the library checks the range [0, 1].
glm::vec3 to_albedo(const py::handle& obj) {
  FArray a = real_array<float>(obj, "albedo");
  if (a.ndim() == 0) return glm::vec3(a.data()[0]);
  if (a.ndim() != 1 || a.shape(0) != 3)
    throw Error("albedo: expected a number or 3 numbers r, g, b, got an array of shape " + shape_text(a));
  return {a.data()[0], a.data()[1], a.data()[2]};
}

py::array_t<double> from_mat(const glm::dmat3& m) {
  py::array_t<double> a({3, 3});
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a.mutable_at(i, j) = m[j][i];  // glm is column-major
  return a;
}

// A rotation: a 3x3 matrix, or (yaw, pitch, roll) in degrees as --rotate.
// A rotation matrix must be one: orthonormal to this (a float32 matrix's
// rounding, 1e-7 per entry, with room) and of determinant +1 (no mirror).
constexpr double kRotationTol = 1e-5;

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

// ---- progress, Ctrl-C ----------------------------------------------------------

// While one lives on Python's main thread, SIGINT sets a flag instead of
// running Python's handler (which cannot run while the GIL is released);
// the destructor puts Python's handler back. Elsewhere, or when SIGINT is not
// Python's default handler, it leaves SIGINT alone.
std::atomic<bool> g_interrupted{false};
void on_sigint(int) { g_interrupted = true; }

class InterruptScope {
 public:
  InterruptScope() {
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
  ~InterruptScope() {
    if (installed_) sigaction(SIGINT, &previous_, nullptr);
  }
  bool interrupted() const { return installed_ && g_interrupted; }
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  bool installed_ = false;
  struct sigaction previous_ {};
};

// The prt::Progress of one computation: checks for Ctrl-C on every call and
// calls the Python callback (done, total, phase) at the start and end of each
// phase and whenever another percent is done. A callback returning False, or
// raising, cancels; its exception is kept and raised once the library has
// stopped. Create and destroy it holding the GIL.
class PyProgress {
 public:
  explicit PyProgress(py::object callback) {
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
  ~PyProgress() = default;
  bool interrupted() const { return interrupts_.interrupted(); }

  prt::Progress callback() {
    return [this](std::size_t done, std::size_t total, const char* phase) { return update(done, total, phase); };
  }

  // After the computation (GIL held): raises what stopped it, if Python did.
  // `e` is the library's exception, rethrown when Python did not stop it.
  [[noreturn]] void rethrow(const std::exception_ptr& e) {
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

 private:
  bool update(std::size_t done, std::size_t total, const char* phase) {
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

  InterruptScope interrupts_;
  py::object fn_;
  std::string phase_;
  int percent_ = -1;
  std::size_t done_ = 0;
  std::atomic<bool> stopped_{false};
  std::unique_ptr<py::error_already_set> error_;
};

// Runs f(progress) without the GIL; Python's reasons for stopping win over
// the library's "cancelled".
template <typename F>
auto run_released(py::object progress, F&& f) {
  PyProgress p(std::move(progress));
  std::exception_ptr failure;
  std::optional<std::invoke_result_t<F, prt::Progress>> result;
  {
    py::gil_scoped_release release;
    try {
      result.emplace(f(p.callback()));
    } catch (...) {
      failure = std::current_exception();
    }
  }
  if (failure) p.rethrow(failure);
  if (p.interrupted()) {  // Ctrl-C after the last progress call: still an interrupt
    PyErr_SetNone(PyExc_KeyboardInterrupt);
    throw py::error_already_set();
  }
  return std::move(*result);
}

// adaptive=, verify_adaptive=, adaptive_any= of precompute and
// precompute_lightmap: prt precompute's --adaptive [TOL], --verify-adaptive
// F and --adaptive-any, the same rules (tools/prt/cmd_precompute.cpp,
// parse_adaptive). None: every point traced; 0 is --adaptive without a
// value (default_adaptive_tolerance(samples)); a TOL in (0, 1), refused
// above max_adaptive_tolerance(samples) unless adaptive_any. Returns the
// options, or nothing for adaptive=None.
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

// threads=: prt's --threads, 0 (every core) to prt::kMaxThreads.
int threads_arg(int threads) {
  if (threads < 0 || threads > prt::kMaxThreads)
    throw Error("threads: must be 0 (every core) to " + std::to_string(prt::kMaxThreads) + ", got " +
                std::to_string(threads));
  return threads;
}

std::unique_ptr<tbb::global_control> limit_threads(int threads) {
  if (threads_arg(threads) == 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
}

// A limit as the command prints it ({:g}: 64, not 64.0).
std::string limit_text(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", x);
  return b;
}

// An exposure in stops given by the caller (not 'auto'): finite (the
// wrapper) and within the command's --exposure range, +-kMaxExposureStops.
double exposure_arg(const py::object& exposure) {
  const DArray ev = real_array<double>(exposure, "exposure");
  if (ev.ndim() != 0) throw Error("exposure: stops (a number) or 'auto'");
  const double stops = ev.data()[0];
  if (!(std::abs(stops) <= prt::kMaxExposureStops))
    throw Error("exposure: must be a number in [-" + limit_text(prt::kMaxExposureStops) + ", " +
                limit_text(prt::kMaxExposureStops) + "] (stops) or 'auto', got " + number_text(stops));
  return stops;
}

// fov=: vertical degrees, prt's --fov range.
void check_fov(double fov) {
  if (!(fov >= prt::kMinFov && fov <= prt::kMaxFov))
    throw Error("fov: vertical degrees, " + limit_text(prt::kMinFov) + " to " + limit_text(prt::kMaxFov) + ", got " +
                number_text(fov));
}

// terms=: the wavelet terms K, 1 to wavelet::kMaxTerms (--terms).
void check_terms(int terms) {
  if (terms < 1 || terms > prt::wavelet::kMaxTerms)
    throw Error("terms: must be 1 to " + std::to_string(prt::wavelet::kMaxTerms) + " (K >= 6 r^2 keeps all), got " +
                std::to_string(terms));
}

// rho_d of diffuse=: a number or (r, g, b), each an albedo in [0, 1] (--diffuse).
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

// uv_set= (and Scene.lightmap_uv_set's requested=): -1 (choose) or 0 to
// kMaxLightmapUvSet, the rule of Scene::lightmap_uv_set, named here.
int uv_set_arg(int uv_set, const char* what) {
  if (uv_set < -1 || uv_set > prt::kMaxLightmapUvSet)
    throw Error(std::string(what) + ": " + std::to_string(uv_set) +
                ": expected -1 (choose: TEXCOORD_1 where every object has it, else TEXCOORD_0) or 0 to " +
                std::to_string(prt::kMaxLightmapUvSet) + " (TEXCOORD_N)");
  return uv_set;
}

// An output file named `what` of a call must be none of its inputs (a file
// named by the call, a Mesh or Scene read from a file): prt's commands' rule
// (the same file through a link too: prt::same_file).
struct NamedInput {
  std::string name, path;
};
void check_not_input(const std::string& what, const std::string& out, const std::vector<NamedInput>& inputs) {
  for (const NamedInput& in : inputs)
    if (prt::same_file(out, in.path))
      throw Error(what + ": " + out + ": is the input " + in.name + (in.path == out ? "" : " (" + in.path + ")") +
                  "; prt does not write over its inputs (choose another output name)");
}

// dims= of precompute_probes: (NX, NY, NZ), three whole numbers by the rule
// of prt::probe_dims_problem (prt precompute --probes NXxNYxNZ's).
std::array<int, 3> probe_dims_arg(const py::object& dims) {
  const std::string rule = "dims: expected (NX, NY, NZ), three whole numbers, each 2 to " +
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
  for (std::size_t k = 0; k < 3; ++k) d[k] = int_arg(seq[k], "dims[" + std::to_string(k) + "]");
  if (const std::string p = prt::probe_dims_problem(d); !p.empty()) throw Error("dims: " + shown + ": " + p);
  return d;
}

// ---- rendering -----------------------------------------------------------------
//
// One OpenGL context for the process: an EGL context is current on one thread
// at a time, so the renderer lives on a thread of its own, made with it on the
// first render() and reused by every later one, whichever Python thread
// calls; calls are served in turn. Stopped at interpreter exit (the renderer
// destroyed on its thread).
class GlWorker {
 public:
  static GlWorker& get() {
    static GlWorker* w = [] {
      started_ = true;
      return new GlWorker();  // lives to the end; atexit stops its thread
    }();
    return *w;
  }
  static bool started() { return started_; }
  // Runs f(renderer) on the GL thread and returns its result, rethrowing its
  // exception; the first call creates the renderer (NoGlContext when there
  // is no OpenGL 4.5: every later call says so again).
  template <typename F>
  auto run(F&& f) -> decltype(f(std::declval<prt::Renderer&>())) {
    using R = decltype(f(std::declval<prt::Renderer&>()));
    std::optional<R> result;
    std::exception_ptr error;
    bool done = false;
    std::mutex m;
    std::condition_variable cv;
    post([&] {
      try {
        if (!renderer_) {
          if (failure_) std::rethrow_exception(failure_);
          try {
            renderer_ = std::make_unique<prt::Renderer>();
          } catch (...) {
            failure_ = std::current_exception();
            throw;
          }
        }
        result.emplace(f(*renderer_));
      } catch (...) {
        error = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(m);
      done = true;
      cv.notify_one();
    });
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [&] { return done; });
    if (error) std::rethrow_exception(error);
    return std::move(*result);
  }
  void stop() {
    if (!thread_.joinable()) return;
    post([this] { renderer_.reset(); });
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    cv_.notify_one();
    thread_.join();
  }

 private:
  GlWorker() : thread_([this] { loop(); }) {}
  void post(std::function<void()> task) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_) throw Error("the renderer has stopped (the interpreter is exiting)");
      tasks_.push_back(std::move(task));
    }
    cv_.notify_one();
  }
  void loop() {
    for (;;) {
      std::function<void()> task;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [this] { return stopping_ || !tasks_.empty(); });
        if (tasks_.empty()) return;  // stopping, and nothing left
        task = std::move(tasks_.front());
        tasks_.pop_front();
      }
      task();
    }
  }
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  bool stopping_ = false;
  std::unique_ptr<prt::Renderer> renderer_;
  std::exception_ptr failure_;
  std::thread thread_;  // last: started once the rest is ready
  static inline std::atomic<bool> started_{false};
};

// ---- transfers -----------------------------------------------------------------

// An SH transfer as Python sees it: the whole transfer (a compressed file's
// rows reconstructed) and, for a compressed file, the compressed form, which
// relight() uses as prt relight does.
struct PyTransfer {
  prt::Transfer t;
  std::optional<prt::CompressedTransfer> compressed;
  std::string source = "<computed>";
};

PyTransfer read_transfer(const std::string& path) {
  PyTransfer p;
  p.source = path;
  const prt::TransferBasis basis = prt::read_transfer_basis(path);
  if (basis == prt::TransferBasis::Wavelet)
    throw Error(path + ": holds a wavelet transfer (prt precompute --basis wavelet); read it with prt.read_wavelet");
  if (basis == prt::TransferBasis::ZH)
    throw Error(path + ": holds a zonal-harmonic (local deformable) transfer (prt precompute --basis zh); read it "
                       "with prt.read_zh");
  if (prt::transfer_is_compressed(path)) {
    p.compressed = prt::read_compressed_transfer(path);
    p.t = prt::decompress(*p.compressed);
  } else {
    p.t = prt::read_transfer(path);
  }
  return p;
}

// A local deformable transfer (prt/zh_transfer.h, docs/LDPRT.md) and where it
// came from, which names it in messages (as PyTransfer's source).
struct PyZhTransfer {
  prt::ZhTransfer z;
  std::string source = "<computed>";
};

// prt::check_matches(p.t, mesh) for a Mesh held by Python, whose hashes are
// kept on the object: a prt.Mesh never changes after it is made (its arrays
// are read-only views, and every function returns a new mesh), so the mesh
// and shading hashes of the same object stay right. The fast path only
// passes what check_matches would pass; anything else goes to check_matches
// for its error. (Hashing 10k vertices costs ~25 us, a third of a 3-band
// relight: bench/python_relight_overhead.py.)
void check_matches_cached(const PyTransfer& p, const py::object& mesh_obj) {
  const auto& mesh = mesh_obj.cast<const prt::Mesh&>();  // mesh_arg checked the type
  py::dict cache = mesh_obj.attr("__dict__");
  const auto cached = [&](const char* key, auto compute) {
    if (!cache.contains(key)) cache[key] = compute();
    return cache[key].cast<std::uint64_t>();
  };
  const bool ok =
      mesh.vertex_count() == p.t.vertices &&
      cached("_prt_mesh_hash", [&] { return mesh.hash(); }) == p.t.mesh_hash &&
      (!p.t.vertex_colors || mesh.colors.size() == mesh.vertex_count()) &&
      (p.t.analytic_vertices() == 0 ||
       (p.t.vertex_colors ? cached("_prt_shading_hash_colors", [&] { return prt::shading_hash(mesh, true); })
                          : cached("_prt_shading_hash", [&] { return prt::shading_hash(mesh, false); })) ==
           p.t.shading_hash);
  if (!ok) prt::check_matches(p.t, mesh, p.source);
}

// A wavelet transfer (prt/wavelet_transfer.h, docs/WAVELETS.md) and its source.
struct PyWavelet {
  prt::WaveletTransfer t;
  std::string source = "<computed>";
};

py::dict pose_report(const prt::PoseReport& r) {
  py::dict d;
  d["no_frame"] = r.no_frame;
  d["normal_only"] = r.normal_only;
  d["uv"] = r.uv;
  return d;
}

py::object rows_view(const PyTransfer& p, const std::vector<float>& a, py::handle self) {
  if (a.empty() && &a != &p.t.coeffs) return py::none();  // no direct part
  const std::size_t nc = std::size_t(p.t.bands) * p.t.bands;
  return view(a.data(), {py::ssize_t(p.t.stored_vertices()), p.t.channels, py::ssize_t(nc)}, self);
}

// ---- the map argument of project() ---------------------------------------------

bool is_path(const py::handle& h) {
  return py::isinstance<py::str>(h) || py::isinstance(h, py::module_::import("os").attr("PathLike"));
}
// A file name argument (str or os.PathLike) as a string; `what` names it.
std::string path_of(const py::handle& h, const std::string& what) {
  if (!is_path(h))
    throw Error(what + ": expected a file name (str or os.PathLike), got " +
                std::string(py::str(py::type::of(h).attr("__name__"))));
  const std::string p = py::str(py::module_::import("os").attr("fspath")(h));
  if (p.empty()) throw Error(what + ": expected a file name, got ''");  // as the command's path options
  return p;
}

prt::EnvMap map_from_array(const py::handle& obj);

// A list or tuple of six file names (str or os.PathLike): a cube's faces
// +X, -X, +Y, -Y, +Z, -Z; anything else is not (an array's nested lists).
std::optional<std::array<std::string, 6>> face_files(const py::handle& h) {
  if (!py::isinstance<py::list>(h) && !py::isinstance<py::tuple>(h)) return std::nullopt;
  const py::sequence seq = py::reinterpret_borrow<py::sequence>(h);
  bool paths = py::len(seq) > 0;
  for (const py::handle item : seq) paths = paths && is_path(item);
  if (!paths) return std::nullopt;
  if (py::len(seq) != 6)
    throw Error("map: a list of " + std::to_string(py::len(seq)) +
                " files; a cube's faces are six files +X, -X, +Y, -Y, +Z, -Z");
  std::array<std::string, 6> f;
  for (std::size_t i = 0; i < 6; ++i) f[i] = path_of(seq[i], "map");
  return f;
}

// A map argument: an EnvMap (returned as is), a file name or an array
// (loaded into `storage`, which is returned).
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

py::dict stats_dict(const prt::MapStats& s) {
  py::dict d;
  d["min"] = s.min;
  d["max"] = s.max;
  d["mean"] = s.mean;
  d["pixels"] = s.pixels;
  d["negative"] = s.negative;
  d["nonfinite"] = s.nonfinite;
  d["first_nonfinite"] = s.first_nonfinite;
  return d;
}

py::dict mesh_report(const prt::MeshReport& r) {
  py::dict d;
  d["degenerate_triangles"] = r.degenerate_triangles;
  d["unreferenced_vertices"] = r.unreferenced_vertices;
  d["normals_computed"] = r.normals_computed;
  d["zero_normals"] = r.zero_normals;
  d["welded"] = r.welded;
  d["nonmanifold_edges"] = r.nonmanifold_edges;
  d["inconsistent_edges"] = r.inconsistent_edges;
  d["file_had_normals"] = r.file_had_normals;
  d["file_had_colors"] = r.file_had_colors;
  return d;
}

prt::MeshOptions mesh_options(bool weld, bool file_normals, const std::string& weighting) {
  prt::MeshOptions o;
  o.weld = weld;
  o.file_normals = file_normals;
  if (weighting == "area")
    o.weighting = prt::NormalWeighting::Area;
  else if (weighting == "angle")
    o.weighting = prt::NormalWeighting::Angle;
  else
    throw Error("weighting: expected 'area' or 'angle', got '" + weighting + "'");
  return o;
}

// An (N, 3) array of finite values (exactly N rows when `rows` is given).
std::vector<glm::vec3> to_vec3s(const py::handle& obj, const char* what, std::optional<std::size_t> rows = {},
                                const char* rows_of = nullptr) {
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

}  // namespace

PYBIND11_MODULE(_prt, m) {
  m.doc() = "prt: Precomputed Radiance Transfer (docs/PYTHON.md)";
  // The renderer's thread stops before the interpreter does (GlWorker).
  py::module_::import("atexit").attr("register")(py::cpp_function([] {
    if (!GlWorker::started()) return;
    py::gil_scoped_release release;
    GlWorker::get().stop();
  }));
  m.attr("__version__") = PRT_VERSION;
  m.attr("MAX_BANDS") = prt::sh::kMaxBands;
  // prt::Error (a user's mistake, naming the file or option) -> prt.Error.
  py::register_exception<Error>(m, "Error", PyExc_RuntimeError);

  m.def("data_dir", [] { return prt::data_dir().string(); },
        "The directory of prt's bundled data (envmaps/): $PRT_DATA_DIR, or the one installed with prt.");

  // ---- maps ----
  py::class_<prt::EnvMap>(m, "EnvMap", "An environment map: linear RGB float pixels (prt/envmap.h)")
      .def_property_readonly(
          "pixels",
          [](py::object self) {
            const auto& e = self.cast<const prt::EnvMap&>();
            if (e.is_cube()) return view(e.rgb.data(), {6, e.width, e.width, 3}, self);
            return view(e.rgb.data(), {e.height, e.width, 3}, self);
          },
          "float32, (H, W, 3) for a lat-long map (row 0 at the top), (6, N, N, 3) for a cube "
          "(+X, -X, +Y, -Y, +Z, -Z); read-only")
      .def_property_readonly("mapping", [](const prt::EnvMap& e) { return std::string(e.is_cube() ? "faces" : "latlong"); },
                             "'latlong' or 'faces' (a cube)")
      .def_property_readonly("width", [](const prt::EnvMap& e) { return e.width; })
      .def_property_readonly("height", [](const prt::EnvMap& e) { return e.height; })
      .def_property_readonly("source", [](const prt::EnvMap& e) { return e.source; })
      .def_property_readonly("source_layout", [](const prt::EnvMap& e) { return e.source_layout; },
                             "How the file stored it: 'lat-long', 'horizontal cross', ...")
      .def_property_readonly("source_channels", [](const prt::EnvMap& e) { return e.source_channels; })
      .def_property_readonly("stats", [](const prt::EnvMap& e) { return stats_dict(e.stats); },
                             "min, max, mean, pixels, negative, nonfinite: what prt project prints")
      .def("__repr__", [](const prt::EnvMap& e) { return "<prt.EnvMap " + prt::describe(e) + ">"; })
      .def("__str__", [](const prt::EnvMap& e) { return prt::describe(e); });

  m.def(
      "load_envmap",
      [](const py::object& path, const std::string& mapping) {
        const prt::Mapping mp = prt::parse_mapping(mapping);
        const std::optional<std::array<std::string, 6>> files = face_files(path);
        if (files) return prt::load_cube_faces(*files);
        if (mp == prt::Mapping::Faces || py::isinstance<py::list>(path) || py::isinstance<py::tuple>(path))
          throw Error("path: mapping 'faces' needs a list of six files +X, -X, +Y, -Y, +Z, -Z");
        return prt::load_envmap(path_of(path, "path"), mp);
      },
      py::arg("path"), py::arg("mapping") = "auto",
      "Reads a map (EXR; HDR, PNG, ... through prt's OpenImageIO plugin). mapping: auto (from the shape), latlong, "
      "hcross, vcross, or faces (path: six files).");

  m.def(
      "read_exr",
      [](const py::object& path) {
        const std::string p = path_of(path, "path");
        prt::RgbaImage img;
        {
          py::gil_scoped_release release;
          img = prt::read_exr_rgba(p);
        }
        if (img.has_alpha) return copy(img.rgba.data(), {py::ssize_t(img.height), py::ssize_t(img.width), 4});
        std::vector<float> rgb(std::size_t(img.width) * img.height * 3);
        for (std::size_t i = 0; i < rgb.size() / 3; ++i)
          std::copy_n(img.rgba.begin() + std::ptrdiff_t(i * 4), 3, rgb.begin() + std::ptrdiff_t(i * 3));
        return copy(rgb.data(), {py::ssize_t(img.height), py::ssize_t(img.width), 3});
      },
      py::arg("path"),
      "The pixels of the EXR image at `path` as float32 (height, width, 4) when it has an alpha channel (prt render --alpha, lightmaps: A is coverage), else (height, width, 3); row 0 at the top.");

  m.def(
      "project",
      [](const py::object& map, int bands, const std::string& mapping, const std::string& quadrature,
         bool irradiance, const std::string& window, double window_width, const py::object& rotate) {
        const prt::Quadrature q = prt::parse_quadrature(quadrature);
        const prt::sh::Window w = prt::sh::parse_window(window);
        if (window_width < 0)  // prt project --window-width: a positive number of bands
          throw Error("window_width: the window's width in bands, > 0 (0: the band count), got " +
                      number_text(window_width));
        std::optional<glm::dmat3> R;
        if (!rotate.is_none()) R = to_rotation(rotate, "rotate");
        std::vector<glm::dvec3> c;
        if (py::isinstance<prt::EnvMap>(map)) {
          const auto& e = map.cast<const prt::EnvMap&>();
          py::gil_scoped_release release;
          c = prt::project(e, bands, q);
        } else if (const auto f = face_files(map)) {  // six face files
          const prt::EnvMap e = prt::load_cube_faces(*f);
          py::gil_scoped_release release;
          c = prt::project(e, bands, q);
        } else if (is_path(map)) {
          const std::string path = path_of(map, "map");
          py::gil_scoped_release release;
          c = prt::project_file(path, bands, q, prt::parse_mapping(mapping)).coeffs;  // as prt project
        } else {
          const prt::EnvMap e = map_from_array(map);
          py::gil_scoped_release release;
          c = prt::project(e, bands, q);
        }
        if (irradiance) prt::sh::scale_bands(std::span<glm::dvec3>(c), prt::sh::clamped_cosine_factors(bands));
        prt::sh::apply_window(std::span<glm::dvec3>(c), w, window_width > 0 ? window_width : bands);
        if (R) {
          std::vector<glm::dvec3> r(c.size());
          prt::sh::Rotation(bands, *R).apply(c, r);
          c.swap(r);
        }
        return from_coeffs(c);
      },
      py::arg("map"), py::arg("bands") = 3, py::kw_only(), py::arg("mapping") = "auto",
      py::arg("quadrature") = "box", py::arg("irradiance") = false, py::arg("window") = "none",
      py::arg("window_width") = 0.0, py::arg("rotate") = py::none(),
      "SH coefficients of a map, as prt project computes them: projection, then irradiance, window and rotation.\n"
      "\n"
      "Arguments (prt project's option in brackets):\n"
      "  map: an EnvMap, a file name, a list of six face files, or an array (H, W, 3) (lat-long) or (6, N, N, 3) (cube faces +X, -X, +Y, -Y, +Z, -Z).\n"
      "  bands: SH bands n, 1 to 64 (MAX_BANDS) [--bands].\n"
      "  mapping: how to read a file: 'auto' (from the shape), 'latlong', 'hcross', 'vcross' or 'faces' [--mapping].\n"
      "  quadrature: 'box' (texels are area averages, integrated exactly) or 'point' (point samples; lat-long only) [--quadrature].\n"
      "  irradiance: convolve with the clamped cosine (Ramamoorthi & Hanrahan's A_l) [--irradiance].\n"
      "  window: 'none', 'hanning', 'lanczos' or 'auto' ringing suppression [--window]; window_width: its width in bands, > 0 (0: the band count) [--window-width].\n"
      "  rotate: a 3x3 rotation R or (yaw, pitch, roll) degrees; light from d arrives from R d [--rotate].\n"
      "\n"
      "Returns float64 (bands*bands, 3), index k = l(l+1)+m (docs/CONVENTIONS.md).");

  m.def(
      "sh_eval",
      [](int bands, const py::object& dirs) {
        prt::sh::check_bands(bands, "bands");
        DArray d = real_array<double>(dirs, "dirs");
        const std::size_t n = rows_of3(d, "dirs");
        const std::size_t nc = std::size_t(bands) * bands;
        std::vector<double> unit(3 * n);
        for (std::size_t i = 0; i < n; ++i) {
          const double* p = d.data() + 3 * i;
          const double len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
          if (!(len > 0) || !std::isfinite(len))
            throw Error("dirs: direction " + std::to_string(i) + " has length " + std::to_string(len) +
                        "; give non-zero finite directions");
          for (int k = 0; k < 3; ++k) unit[3 * i + k] = p[k] / len;
        }
        py::array_t<double> out(d.ndim() == 1 ? std::vector<py::ssize_t>{py::ssize_t(nc)}
                                              : std::vector<py::ssize_t>{py::ssize_t(n), py::ssize_t(nc)});
        prt::sh::eval_batch(bands, unit.data(), n, out.mutable_data());
        return out;
      },
      py::arg("bands"), py::arg("dirs"),
      "The real SH basis functions at directions.\n"
      "\n"
      "Arguments:\n"
      "  bands: n, 1 to 64 (MAX_BANDS); dirs: (N, 3) directions (normalised first).\n"
      "\n"
      "Returns float64 (N, bands*bands), index k = l(l+1)+m (docs/CONVENTIONS.md).");

  m.def("rotation_from_euler",
        [](double yaw, double pitch, double roll) {
          for (const auto& [name, x] : {std::pair{"yaw", yaw}, std::pair{"pitch", pitch}, std::pair{"roll", roll}})
            if (!std::isfinite(x)) throw Error(std::string(name) + ": " + number_text(x) + " degrees; must be finite");
          return from_mat(prt::sh::rotation_from_euler(yaw, pitch, roll));
        },
        py::arg("yaw"), py::arg("pitch"), py::arg("roll"),
        "The 3x3 matrix --rotate yaw,pitch,roll (degrees) means: R = Ry(yaw) Rx(pitch) Rz(roll).");

  m.def(
      "rotate_sh",
      [](const py::object& coeffs, const py::object& rotation) {
        DArray c = real_array<double>(coeffs, "coeffs");
        if (c.ndim() < 1 || c.ndim() > 2 || c.shape(0) < 1)
          throw Error("coeffs: expected an array of shape (n*n,) or (n*n, C), got " + shape_text(c));
        const std::size_t nc = std::size_t(c.shape(0));
        const int bands = bands_of_count(nc, "coeffs");
        const std::size_t cols = c.ndim() == 2 ? std::size_t(c.shape(1)) : 1;
        const prt::sh::Rotation rot(bands, to_rotation(rotation, "rotation"));
        py::array_t<double> out(c.request().shape);
        std::vector<double> in(nc), res(nc);
        for (std::size_t j = 0; j < cols; ++j) {
          for (std::size_t k = 0; k < nc; ++k) in[k] = c.data()[k * cols + j];
          rot.apply(std::span<const double>(in), std::span<double>(res));
          for (std::size_t k = 0; k < nc; ++k) out.mutable_data()[k * cols + j] = res[k];
        }
        return out;
      },
      py::arg("coeffs"), py::arg("rotation"),
      "Rotates SH coefficients: the lighting turned so that light from d arrives from R d (prt's --rotate).\n"
      "\n"
      "Arguments:\n"
      "  coeffs: (n*n,) or (n*n, C).\n"
      "  rotation: a 3x3 rotation matrix R, or (yaw, pitch, roll) degrees as --rotate.\n"
      "\n"
      "Returns float64 of coeffs' shape.");

  // ---- meshes ----
  py::class_<prt::Mesh>(m, "Mesh", "A triangle mesh as prt loads it (prt/mesh.h)", py::dynamic_attr())
      .def_property_readonly("positions",
                             [](py::object self) {
                               const auto& x = self.cast<const prt::Mesh&>();
                               return view3(x.positions, self);
                             },
                             "float32 (V, 3), read-only")
      .def_property_readonly("normals",
                             [](py::object self) {
                               const auto& x = self.cast<const prt::Mesh&>();
                               return view3(x.normals, self);
                             },
                             "float32 (V, 3), unit or zero, read-only")
      .def_property_readonly("triangles",
                             [](py::object self) {
                               const auto& x = self.cast<const prt::Mesh&>();
                               return view3(x.triangles, self);
                             },
                             "uint32 (T, 3) vertex indices, counter-clockwise seen from the front, read-only")
      .def_property_readonly("colors",
                             [](py::object self) -> py::object {
                               const auto& x = self.cast<const prt::Mesh&>();
                               if (x.colors.empty()) return py::none();
                               return view3(x.colors, self);
                             },
                             "float32 (V, 3) linear RGB from the file, or None")
      .def_property_readonly("corner_uvs",
                             [](py::object self) -> py::object {
                               const auto& x = self.cast<const prt::Mesh&>();
                               if (x.corner_uvs.empty()) return py::none();
                               return view(&x.corner_uvs[0].x, {py::ssize_t(x.triangles.size()), 3, 2}, self);
                             },
                             "float32 (T, 3, 2) texture coordinates per triangle corner (load_mesh(uvs=True)), or None")
      .def_property_readonly("vertex_count", &prt::Mesh::vertex_count)
      .def_property_readonly("source", [](const prt::Mesh& x) { return x.source; })
      .def_property_readonly("hash", &prt::Mesh::hash, "XXH3-64 of positions and triangles (a transfer's mesh_hash)")
      .def_property_readonly("report", [](const prt::Mesh& x) { return mesh_report(x.report); })
      .def("__len__", &prt::Mesh::vertex_count)
      .def("__repr__", [](const prt::Mesh& x) { return "<prt.Mesh " + prt::describe(x) + ">"; })
      .def("__str__", [](const prt::Mesh& x) { return prt::describe(x); });

  m.def(
      "load_mesh",
      [](const py::object& path, bool weld, bool file_normals, const std::string& weighting, bool uvs) {
        prt::MeshOptions o = mesh_options(weld, file_normals, weighting);
        o.uvs = uvs;
        const std::string p = path_of(path, "path");
        py::gil_scoped_release release;
        return prt::load_mesh(p, o);
      },
      py::arg("path"), py::kw_only(), py::arg("weld") = false, py::arg("file_normals") = true,
      py::arg("weighting") = "area", py::arg("uvs") = false,
      "Reads a mesh file as every prt command does.\n"
      "\n"
      "Arguments:\n"
      "  path: OBJ, PLY, OFF, STL, glTF/GLB.\n"
      "  weld: merge vertices that share a position [--weld].\n"
      "  weighting: how vertex normals are averaged where they are computed: 'area' (the default) or 'angle' (corner angles).\n"
      "  file_normals: keep the file's normals where it has them (True; False: compute them).\n"
      "  uvs: also read the first texture coordinates per triangle corner (Mesh.corner_uvs): fit_zh's vertex frames take their tangent from them, as prt precompute --basis zh (--tangent uv, the default).\n"
      "\n"
      "Returns a Mesh (immutable).");

  m.def(
      "make_mesh",
      [](const py::object& positions, const py::object& triangles, const py::object& normals,
         const py::object& colors, bool weld) {
        std::vector<glm::vec3> pos = to_vec3s(positions, "positions");
        if (pos.empty()) throw Error("positions: no vertices (an array of shape (0, 3))");
        UArray t = index_array(triangles, "triangles");
        if (t.ndim() != 2 || t.shape(1) != 3 || t.shape(0) < 1)
          throw Error("triangles: expected an integer array of shape (T, 3), T >= 1, got " + shape_text(t));
        for (std::size_t k = 0; k < std::size_t(t.size()); ++k)
          if (t.data()[k] >= pos.size())
            throw Error("triangles: element " + index_text(k, t) + " is " + std::to_string(t.data()[k]) +
                        ", out of range: positions holds " + std::to_string(pos.size()) + " vertices");
        std::vector<glm::uvec3> tri(std::size_t(t.shape(0)));
        if (!tri.empty()) std::memcpy(&tri[0].x, t.data(), tri.size() * sizeof(glm::uvec3));
        const std::size_t V = pos.size();
        std::vector<glm::vec3> n =
            normals.is_none() ? std::vector<glm::vec3>{} : to_vec3s(normals, "normals", V, "position");
        std::vector<glm::vec3> c = colors.is_none() ? std::vector<glm::vec3>{} : to_vec3s(colors, "colors", V, "position");
        prt::MeshOptions o;
        o.weld = weld;
        return prt::make_mesh(std::move(pos), std::move(tri), std::move(n), std::move(c), o, "<arrays>");
      },
      py::arg("positions"), py::arg("triangles"), py::arg("normals") = py::none(), py::arg("colors") = py::none(),
      py::kw_only(), py::arg("weld") = false,
      "A mesh from arrays, checked as a loaded one.\n"
      "\n"
      "Arguments:\n"
      "  positions: (V, 3) finite, float32 range; triangles: (T, 3) vertex indices (whole numbers).\n"
      "  normals: (V, 3), or None to compute them (angle-weighted); colors: (V, 3) linear RGB in [0, 1], or None.\n"
      "  weld: merge vertices that share a position.\n"
      "\n"
      "Returns a Mesh.");

  // ---- transfers ----
  py::class_<PyTransfer>(m, "Transfer", "An SH transfer (prt/transfer.h): per-vertex transfer vectors")
      .def_property_readonly("bands", [](const PyTransfer& p) { return p.t.bands; })
      .def_property_readonly("channels", [](const PyTransfer& p) { return p.t.channels; })
      .def_property_readonly("mode", [](const PyTransfer& p) { return std::string(prt::transfer_mode_name(p.t.mode)); })
      .def_property_readonly("bounces", [](const PyTransfer& p) { return p.t.bounces; })
      .def_property_readonly("samples", [](const PyTransfer& p) { return p.t.samples; })
      .def_property_readonly("albedo", [](const PyTransfer& p) { return py::make_tuple(p.t.albedo.x, p.t.albedo.y, p.t.albedo.z); })
      .def_property_readonly("vertex_colors", [](const PyTransfer& p) { return p.t.vertex_colors; })
      .def_property_readonly("seed", [](const PyTransfer& p) { return p.t.seed; })
      .def_property_readonly("vertices", [](const PyTransfer& p) { return p.t.vertices; })
      .def_property_readonly("mesh_hash", [](const PyTransfer& p) { return p.t.mesh_hash; })
      .def_property_readonly("glossy", [](const PyTransfer& p) { return p.t.glossy; },
                             "Whether it holds glossy matrices (relight() uses the diffuse part)")
      .def_property_readonly("compressed", [](const PyTransfer& p) { return p.compressed.has_value(); },
                             "Read from a compressed file (prt compress): rows are reconstructed")
      .def_property_readonly("source", [](const PyTransfer& p) { return p.source; })
      .def_property_readonly("analytic_vertices", [](const PyTransfer& p) { return p.t.analytic_vertices(); })
      .def_property_readonly("stored_vertices", [](const PyTransfer& p) { return p.t.stored_vertices(); })
      .def_property_readonly(
          "analytic",
          [](const PyTransfer& p) {
            py::array_t<bool> a(py::ssize_t(p.t.vertices));
            for (std::size_t v = 0; v < p.t.vertices; ++v) a.mutable_at(v) = p.t.is_analytic(v);
            return a;
          },
          "bool (V,): vertices that store no row (unoccluded: transfer evaluated from the mesh's normal)")
      .def_property_readonly(
          "slots",
          [](const PyTransfer& p) {
            py::array_t<std::int64_t> a(py::ssize_t(p.t.vertices));
            for (std::size_t v = 0; v < p.t.vertices; ++v)
              a.mutable_at(v) = p.t.slots.empty() ? std::int64_t(v)
                                : p.t.slots[v] == prt::Transfer::kAnalytic ? -1
                                                                           : std::int64_t(p.t.slots[v]);
            return a;
          },
          "int64 (V,): each vertex's row in rows, or -1 when analytic")
      .def_property_readonly("interpolated_vertices", [](const PyTransfer& p) { return p.t.interpolated_vertices(); },
                             "How many vertices were interpolated from traced neighbours (prt precompute --adaptive); "
                             "0 when every vertex was traced")
      .def_property_readonly("interpolated",
                             [](py::object self) -> py::object {
                               const auto& p = self.cast<const PyTransfer&>();
                               if (p.t.interpolated.empty()) return py::none();
                               return view(p.t.interpolated.data(), {py::ssize_t(p.t.interpolated.size())}, self);
                             },
                             "uint8 (V,), read-only: 1 where the vertex's transfer was interpolated from traced "
                             "neighbours (adaptive sample points, prt precompute --adaptive), 0 where it was traced; "
                             "None when every vertex was traced (the file has no 'interpolated vertices' mask)")
      .def_property_readonly("rows", [](py::object self) { const auto& p = self.cast<const PyTransfer&>(); return rows_view(p, p.t.coeffs, self); },
                             "float32 (stored vertices, channels, bands^2): the stored rows, read-only")
      .def_property_readonly("direct_rows", [](py::object self) { const auto& p = self.cast<const PyTransfer&>(); return rows_view(p, p.t.direct, self); },
                             "Interreflected: the direct (shadowed) part's rows, or None")
      .def_property_readonly("ao",
                             [](py::object self) -> py::object {
                               const auto& p = self.cast<const PyTransfer&>();
                               if (p.t.ao.empty()) return py::none();
                               return view(p.t.ao.data(), {py::ssize_t(p.t.ao.size())}, self);
                             },
                             "float32 (V,) ambient occlusion, or None")
      .def_property_readonly("bent_normals",
                             [](py::object self) -> py::object {
                               const auto& p = self.cast<const PyTransfer&>();
                               if (p.t.bent_normals.empty()) return py::none();
                               return view3(p.t.bent_normals, self);
                             },
                             "float32 (V, 3), or None")
      .def_property_readonly("bounce_energy", [](const PyTransfer& p) { return p.t.bounce_energy; })
      .def(
          "dense",
          [](const PyTransfer& p, const prt::Mesh& mesh, bool direct) {
            prt::check_matches(p.t, mesh, p.source);
            const std::vector<float> d = prt::dense_transfer(p.t, mesh, direct);
            return copy(d.data(), {py::ssize_t(p.t.vertices), p.t.channels, py::ssize_t(p.t.bands) * p.t.bands});
          },
          py::arg("mesh"), py::arg("direct") = false,
          "float32 (V, channels, bands^2): every vertex's transfer, analytic ones evaluated from `mesh` "
          "(the mesh it was computed for); direct=True: an interreflected transfer's direct (0-bounce) part")
      .def(
          "write",
          [](const PyTransfer& p, const py::object& path) {
            const std::string f = path_of(path, "path");
            if (p.compressed)
              prt::write_compressed_transfer(f, *p.compressed);
            else
              prt::write_transfer(f, p.t);
          },
          py::arg("path"), "Writes the file to `path` (atomically) as prt precompute does (docs/FORMAT.md); a compressed transfer as prt compress does.")
      .def("__repr__",
           [](const PyTransfer& p) {
             return "<prt.Transfer " + p.source + ": " + std::string(prt::transfer_mode_name(p.t.mode)) + ", " +
                    std::to_string(p.t.bands) + " bands, " + std::to_string(p.t.channels) + " channel(s), " +
                    std::to_string(p.t.vertices) + " vertices>";
           })
      .def("__str__", [](const PyTransfer& p) {
        return p.compressed ? prt::describe_transfer(*p.compressed) : prt::describe_transfer(p.t);
      });

  m.def("read_transfer", [](const py::object& path) { return read_transfer(path_of(path, "path")); }, py::arg("path"),
        "Reads the SH transfer file at `path` (compressed ones too: their rows are reconstructed); refuses wavelet and zonal-harmonic files, naming read_wavelet and read_zh. Returns a Transfer.");

  m.def(
      "precompute",
      [](const prt::Mesh& mesh, const py::object& bands_arg, int samples, const std::string& mode, int bounces,
         const py::object& albedo, bool vertex_colors, std::uint64_t seed, int threads, double offset,
         double bounce_tolerance, const std::string& material, const std::string& basis, int cube_res,
         double threshold, const py::object& adaptive, double verify_adaptive, bool adaptive_any,
         py::object progress) -> py::object {
        if (basis != "sh" && basis != "wavelet")
          throw Error("basis: expected 'sh' or 'wavelet' (for 'zh', fit_zh the SH transfer), got '" + basis + "'");
        const std::optional<prt::AdaptiveOptions> adapt = adaptive_arg(adaptive, verify_adaptive, adaptive_any, samples);
        if (basis == "wavelet") {
          if (adapt)
            throw Error("adaptive: applies to basis='sh' (SH transfer); a wavelet transfer traces every vertex");
          // The CLI's rules: shadowed, diffuse; its size set by cube_res and threshold.
          if (!bands_arg.is_none()) throw Error("bands: does not apply to basis='wavelet' (cube_res and threshold set its size)");
          if (mode != "shadowed") throw Error("mode: basis='wavelet' is shadowed only, got '" + mode + "'");
          if (material != "diffuse") throw Error("material: basis='wavelet' is diffuse only");
          prt::WaveletOptions w;
          w.cube_res = cube_res;
          w.threshold = threshold;
          w.albedo = to_albedo(albedo);
          w.vertex_colors = vertex_colors;
          w.threads = threads_arg(threads);
          w.offset = offset;
          PyWavelet p;
          p.t = run_released(std::move(progress),
                             [&](const prt::Progress& pr) { return prt::compute_wavelet_transfer(mesh, w, pr); });
          return py::cast(std::move(p));
        }
        if (cube_res != 32 || threshold != 1e-2)
          throw Error(std::string(cube_res != 32 ? "cube_res" : "threshold") + ": applies to basis='wavelet' only");
        const int bands = bands_arg.is_none() ? 5 : int_arg(bands_arg, "bands");
        prt::TransferOptions o;
        o.mode = prt::parse_transfer_mode(mode);
        o.bands = bands;
        o.samples = samples;
        o.bounces = bounces;
        o.albedo = to_albedo(albedo);
        o.vertex_colors = vertex_colors;
        o.seed = seed;
        o.threads = threads_arg(threads);
        o.offset = offset;
        o.bounce_tolerance = bounce_tolerance;
        if (material != "diffuse" && material != "glossy")
          throw Error("material: expected 'diffuse' or 'glossy', got '" + material + "'");
        o.glossy = material == "glossy";
        PyTransfer p;
        p.t = run_released(std::move(progress), [&](const prt::Progress& pr) {
          return adapt ? prt::compute_adaptive_transfer(mesh, o, *adapt, pr) : prt::compute_transfer(mesh, o, pr);
        });
        return py::cast(std::move(p));
      },
      py::arg("mesh"), py::kw_only(), py::arg("bands") = py::none(), py::arg("samples") = 1024,
      py::arg("mode") = "shadowed", py::arg("bounces") = 1, py::arg("albedo") = 0.8, py::arg("vertex_colors") = false,
      py::arg("seed") = 1, py::arg("threads") = 0, py::arg("offset") = 0.0, py::arg("bounce_tolerance") = 0.0,
      py::arg("material") = "diffuse", py::arg("basis") = "sh", py::arg("cube_res") = 32, py::arg("threshold") = 1e-2,
      py::arg("adaptive") = py::none(), py::arg("verify_adaptive") = 0.0, py::arg("adaptive_any") = false,
      py::arg("progress") = py::none(),
      "Traces the transfer of every vertex (or, with adaptive=, of a subset, interpolating the rest), as prt precompute MESH does: the same defaults, and with the same seed and inputs the same bits. Releases the GIL while it traces.\n"
      "\n"
      "Arguments (prt precompute's option in brackets):\n"
      "  mesh: the Mesh (load_mesh, make_mesh); units are the mesh's.\n"
      "  bands: SH bands n, n*n coefficients per channel, 1 to 16 (None: 5) [--bands].\n"
      "  samples: rays per vertex (about), 1 to 2^24 (1024) [--samples].\n"
      "  mode: 'unshadowed' (no rays), 'shadowed' or 'interreflected' [--mode].\n"
      "  bounces: diffuse bounces of 'interreflected', 0 to 64 (1) [--bounces].\n"
      "  albedo: diffuse albedo, a number or (r, g, b), each in [0, 1] (0.8) [--albedo].\n"
      "  vertex_colors: the mesh's vertex colours as albedo [--vertex-colors].\n"
      "  seed: seed of the direction set, 0 to 2^64 - 1 (1) [--seed].\n"
      "  threads: worker threads, 0 (every core) to 1024 [--threads]; the result does not depend on it.\n"
      "  offset: ray origin offset along the normal in mesh units (0: 1e-4 x the bounding-box diagonal) [--offset].\n"
      "  bounce_tolerance: stop adding bounces once one adds less than this fraction of the direct energy, [0, 1) (0: never) [--bounce-tolerance].\n"
      "  material: 'diffuse', or 'glossy': also the transfer matrices of glossy PRT (at most 12 bands; docs/GLOSSY.md) [--material].\n"
      "  basis: 'sh'; or 'wavelet': a WaveletTransfer (shadowed, diffuse; samples, seed and bounces do not apply: one ray per cube texel) [--basis].\n"
      "  cube_res: wavelet basis: the cube's face size r, a power of two 2 to 256 (32) [--cube-res].\n"
      "  threshold: wavelet basis: the relative L2 error each vertex's kept coefficients may leave, [0, 1) (0.01) [--threshold].\n"
      "  adaptive: adaptive sample points (basis='sh'; docs/PRECOMPUTE.md): None traces every vertex; a tolerance TOL in (0, 1) traces a subset and interpolates the rest along the surface where probes show interpolation adds at most TOL (relative RMS, band-weighted); 0: the default TOL, 0.01, and 0.01 x sqrt(1024 / samples) past 1024 samples [--adaptive [TOL]: 0 is the option without a value]. The Transfer's .interpolated marks the interpolated vertices.\n"
      "  verify_adaptive: with adaptive: trace this fraction, [0, 1], of the interpolated vertices again (they keep the traced transfer) (0) [--verify-adaptive].\n"
      "  adaptive_any: with adaptive: take a TOL above 1.5x the default, which is refused otherwise [--adaptive-any].\n"
      "  progress: None, True (a line on stderr) or a callable (done, total, phase) returning False to stop; Ctrl-C stops it (KeyboardInterrupt).\n"
      "\n"
      "Returns a Transfer (a WaveletTransfer for basis='wavelet').");

  m.def(
      "relight",
      [](const PyTransfer& p, const py::object& mesh_obj, const py::object& lighting, bool direct,
         const py::object& eye, double gloss, double specular, const py::object& diffuse) -> py::object {
        if (!py::isinstance<prt::Mesh>(mesh_obj))
          throw Error("mesh: expected a prt.Mesh (load_mesh, make_mesh), got " +
                      std::string(py::str(py::type::of(mesh_obj).attr("__name__"))));
        const auto& mesh = mesh_obj.cast<const prt::Mesh&>();
        const std::vector<glm::dvec3> light = to_coeffs(lighting, "lighting");
        const std::size_t need = std::size_t(p.t.bands) * p.t.bands;
        if (light.size() < need)
          throw Error("lighting: " + std::to_string(light.size()) + " coefficients; " + p.source + " has " +
                      std::to_string(p.t.bands) + " bands and needs " + std::to_string(need));
        check_matches_cached(p, mesh_obj);
        if (direct && p.t.mode != prt::TransferMode::Interreflected)
          throw Error(p.source + ": direct=True needs an interreflected transfer; this one is " +
                      std::string(prt::transfer_mode_name(p.t.mode)));
        if (direct && p.compressed)
          throw Error(p.source + ": direct=True: a compressed transfer keeps no direct part");
        if (eye.is_none()) {
          for (const auto& [name, given] : {std::pair{"gloss", gloss != 16.0}, std::pair{"specular", specular != 0.5},
                                            std::pair{"diffuse", !diffuse.is_none()}})
            if (given)
              throw Error(std::string(name) + ": shapes the glossy part, which needs eye= (the point the vertices are "
                          "seen from)");
          std::vector<glm::vec3> rgb;
          {
            py::gil_scoped_release release;
            rgb = p.compressed ? prt::relight(*p.compressed, mesh, light)
                  : direct     ? prt::relight_direct(p.t, mesh, light)
                               : prt::relight(p.t, mesh, light);
          }
          return vec3s(rgb);
        }
        // Glossy: toward one eye (3,) -> (V, 3), or many (E, 3) -> (E, V, 3).
        if (direct) throw Error("direct: the glossy part (eye=) has no direct-only form");
        const DArray eyes = real_array<double>(eye, "eye");
        if (!(eyes.ndim() == 1 && eyes.shape(0) == 3) && !(eyes.ndim() == 2 && eyes.shape(1) == 3 && eyes.shape(0) >= 1))
          throw Error("eye: expected a point (3,) or points (E, 3), E >= 1, got shape " + shape_text(eyes));
        prt::GlossyShading shading;
        shading.gloss = gloss;
        shading.specular = specular;
        if (!diffuse.is_none()) shading.diffuse = diffuse_arg(diffuse);
        const std::size_t E = eyes.ndim() == 1 ? 1 : std::size_t(eyes.shape(0));
        std::vector<glm::vec3> rgb;
        rgb.reserve(E * mesh.vertex_count());
        for (std::size_t e = 0; e < E; ++e) {
          shading.eye = {eyes.data()[3 * e], eyes.data()[3 * e + 1], eyes.data()[3 * e + 2]};
          if (auto problem = prt::glossy_shading_problem(p.t, shading); !problem.empty())
            throw Error(p.source + ": " + problem);
          py::gil_scoped_release release;
          const std::vector<glm::vec3> one = p.compressed ? prt::relight_glossy(*p.compressed, mesh, light, shading)
                                                          : prt::relight_glossy(p.t, mesh, light, shading);
          rgb.insert(rgb.end(), one.begin(), one.end());
        }
        if (eyes.ndim() == 1) return vec3s(rgb);
        return copy(reinterpret_cast<const float*>(rgb.data()),
                    {py::ssize_t(E), py::ssize_t(mesh.vertex_count()), 3});
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("lighting"), py::kw_only(), py::arg("direct") = false,
      py::arg("eye") = py::none(), py::arg("gloss") = 16.0, py::arg("specular") = 0.5,
      py::arg("diffuse") = py::none(),
      "Outgoing radiance under SH lighting, as prt relight computes it (a glossy transfer's diffuse part without eye=).\n"
      "\n"
      "Arguments (prt relight's option in brackets):\n"
      "  transfer: a Transfer (precompute, read_transfer, compress).\n"
      "  mesh: the Mesh it was computed for (checked).\n"
      "  lighting: coefficients (n*n, 3) or (n*n,) (project()); at least the transfer's bands.\n"
      "  direct: an interreflected transfer's direct (0-bounce) part only [--direct].\n"
      "  eye: a glossy transfer's eye point (3,) in mesh units, or (E, 3) for E eyes [--eye].\n"
      "  gloss: the Phong exponent e, 0 to 4096 (16) [--gloss]; specular: the lobe's strength rho_s in [0, 1] (0.5) [--specular].\n"
      "  diffuse: rho_d, a number or (r, g, b) in [0, 1] (None: the transfer's own albedo) [--diffuse]. docs/GLOSSY.md.\n"
      "\n"
      "Returns float32 (V, 3) linear RGB radiance; with eye (E, 3): (E, V, 3).");

  // ---- rendering (prt/render.h; docs/RUNTIME.md) ----
  m.def(
      "render",
      [](const py::object& transfer, const py::object& mesh_arg, const py::object& map, int width, int height,
         const py::object& camera, double fov, const py::object& rotate, const py::object& exposure,
         const std::string& tone_map, bool linear, const py::object& shading, const py::object& bands_arg,
         double gloss, double specular, const py::object& diffuse, const py::object& deform, double amount, int terms,
         const std::string& selection, bool alpha, const py::object& probes, const py::object& object,
         const py::object& object_at, double object_size) {
        const bool is_zh = py::isinstance<PyZhTransfer>(transfer), is_wavelet = py::isinstance<PyWavelet>(transfer);
        const bool is_lightmap = py::isinstance<prt::LightmapTransfer>(transfer);
        if (!is_zh && !is_wavelet && !is_lightmap && !py::isinstance<PyTransfer>(transfer))
          throw Error("transfer: expected a Transfer, a WaveletTransfer, a ZhTransfer or a Lightmap (read_transfer, "
                      "precompute, compress, read_wavelet, read_zh, fit_zh, read_lightmap, precompute_lightmap)");
        // A lightmap draws its scene; every other transfer its mesh.
        if (is_lightmap ? !py::isinstance<prt::Scene>(mesh_arg) : !py::isinstance<prt::Mesh>(mesh_arg))
          throw Error(is_lightmap ? "mesh: a Lightmap is drawn on its Scene (load_scene), not a " +
                                        std::string(py::str(py::type::of(mesh_arg).attr("__name__")))
                                  : "mesh: expected a Mesh (load_mesh, make_mesh), not a " +
                                        std::string(py::str(py::type::of(mesh_arg).attr("__name__"))) +
                                        (py::isinstance<prt::Scene>(mesh_arg) ? " (a Scene goes with its Lightmap)" : ""));
        const prt::LightmapTransfer* lm = is_lightmap ? &transfer.cast<const prt::LightmapTransfer&>() : nullptr;
        const prt::Scene* world = is_lightmap ? &mesh_arg.cast<const prt::Scene&>() : nullptr;
        const prt::Mesh& mesh = is_lightmap ? world->mesh : mesh_arg.cast<const prt::Mesh&>();
        const PyTransfer* p = is_zh || is_wavelet || is_lightmap ? nullptr : &transfer.cast<const PyTransfer&>();
        const PyZhTransfer* z = is_zh ? &transfer.cast<const PyZhTransfer&>() : nullptr;
        const PyWavelet* wt = is_wavelet ? &transfer.cast<const PyWavelet&>() : nullptr;
        static const std::string lightmap_source = "transfer (the lightmap)";
        const std::string& source = is_zh ? z->source : is_wavelet ? wt->source : is_lightmap ? lightmap_source : p->source;
        if (is_lightmap) {
          if (lm->layout.scene_hash != world->hash())
            throw Error("transfer: the lightmap was computed for another scene than `mesh` (scene hashes differ)");
        } else if (is_zh)
          prt::check_matches(z->z, mesh, source);
        else if (is_wavelet)
          prt::check_matches(wt->t, mesh, source);
        else
          prt::check_matches(p->t, mesh, source);
        // The wavelet terms: a wavelet transfer's (relit on the CPU each frame, drawn as vertex colours).
        if (!is_wavelet && (terms != 100 || selection != "area"))
          throw Error(std::string(terms != 100 ? "terms" : "selection") + ": applies to a wavelet transfer");
        if (is_wavelet && !bands_arg.is_none()) throw Error("bands: a wavelet transfer has no SH bands to limit");
        check_terms(terms);
        const prt::wavelet::Selection sel = [&] {
          try {
            return prt::wavelet::parse_selection(selection);
          } catch (const Error& e) {
            throw Error(std::string("selection: ") + e.what());
          }
        }();
        // A wavelet transfer's SH lighting is Lambert's (3 bands), as prt render.
        const int file_bands = is_zh ? z->z.bands : is_wavelet ? 3 : is_lightmap ? lm->transfer.bands : p->t.bands;
        const bool glossy = p != nullptr && p->t.glossy;
        if (file_bands > prt::kMaxRenderBands)
          throw Error(source + ": " + std::to_string(file_bands) + " bands; the renderer draws at most " +
                      std::to_string(prt::kMaxRenderBands));
        if (width < 1 || height < 1 || width > 16384 || height > 16384)
          throw Error("width, height: 1 to 16384 pixels each, got " + std::to_string(width) + " x " +
                      std::to_string(height));
        check_fov(fov);
        const int bands = bands_arg.is_none() ? file_bands : int_arg(bands_arg, "bands");
        if (bands < 1 || bands > file_bands)
          throw Error("bands: 1 to the transfer's " + std::to_string(file_bands) + ", got " + std::to_string(bands));
        // The shading: the renderer's default for the file (glossy: the lobe too), or the one named.
        const prt::Shading shade = [&] {
          if (shading.is_none()) return glossy ? prt::Shading::Glossy : prt::Shading::Transfer;
          prt::Shading sh;
          try {
            sh = prt::parse_shading(shading.cast<std::string>());
          } catch (const Error& e) {
            throw Error(std::string("shading: ") + e.what());
          }
          if ((is_wavelet || is_zh) && sh != prt::Shading::Transfer && sh != prt::Shading::Lambert)
            throw Error("shading: a " + std::string(is_wavelet ? "wavelet" : "zonal-harmonic") +
                        " transfer shows 'transfer' or 'lambert'");
          if (is_lightmap && sh != prt::Shading::Transfer && sh != prt::Shading::Direct)
            throw Error("shading: a lightmap shows 'transfer' or (interreflected) 'direct'");
          return sh;
        }();
        if (!glossy && (gloss != 16.0 || specular != 0.5 || !diffuse.is_none()))
          throw Error(source + ": gloss, specular and diffuse need a glossy transfer (precompute(material='glossy'))");
        const glm::dvec3 rho_d = diffuse.is_none() ? glm::dvec3(-1.0) : diffuse_arg(diffuse);
        std::optional<prt::Deform> pose;
        if (!deform.is_none()) {
          if (!is_zh) throw Error(source + ": deform needs a zonal-harmonic transfer (fit_zh; docs/LDPRT.md)");
          pose = prt::parse_deform(deform.cast<std::string>());
          if (!std::isfinite(amount)) throw Error("amount: must be finite (0: the rest pose, 1: the whole angle)");
        }
        // An object lit by a probe volume, drawn with the mesh or scene (prt render --probes --object).
        std::optional<prt::ProbeTransfer> volume;
        const prt::Mesh* probe_mesh = nullptr;
        prt::ProbeObjectPlacement place;
        if (probes.is_none() != object.is_none()) throw Error("probes and object go together (a volume and the Mesh it lights)");
        if (probes.is_none() && (!object_at.is_none() || object_size != 0.0))
          throw Error(std::string(object_at.is_none() ? "object_size" : "object_at") + ": applies to a probe-lit object (probes=, object=)");
        if (!probes.is_none()) {
          if (!py::isinstance<prt::ProbeTransfer>(probes))
            throw Error("probes: expected a ProbeVolume (read_probes, precompute_probes)");
          if (!py::isinstance<prt::Mesh>(object)) throw Error("object: expected a Mesh (load_mesh, make_mesh)");
          volume = probes.cast<const prt::ProbeTransfer&>();
          probe_mesh = &object.cast<const prt::Mesh&>();
          // The volume's scene hash covers the scene's UV sets, which a Mesh lacks: a Mesh read from a
          // file is checked against the scene in that file, as prt render --probes checks MESH (a glTF's
          // scene and mesh readers may differ in a position's last bit, so not the mesh's own hash).
          const auto matches = [&] {
            if (world) return world->hash() == volume->scene_hash;
            if (prt::make_scene(mesh.positions, mesh.triangles, {}, {}, {}, {}, mesh.normals).hash() == volume->scene_hash)
              return true;
            std::error_code ec;
            if (mesh.source.empty() || !std::filesystem::is_regular_file(mesh.source, ec)) return false;
            const prt::Scene from_file = prt::load_scene_or_mesh(mesh.source);
            return from_file.mesh.vertex_count() == mesh.vertex_count() && from_file.hash() == volume->scene_hash;
          };
          if (!matches())
            throw Error("probes: computed for another scene than the one drawn (scene hashes differ; pass the Scene or "
                        "Mesh the volume was computed for)");
          if (!std::isfinite(object_size) || object_size < 0)
            throw Error("object_size: the object's bounding-box diagonal in scene units, > 0 (0: twice the probe spacing)");
          place.size = object_size;
          if (!object_at.is_none()) {
            const DArray at = real_array<double>(object_at, "object_at");
            if (at.ndim() != 1 || at.shape(0) != 3) throw Error("object_at: 3 numbers x, y, z, got shape " + shape_text(at));
            place.at = glm::dvec3(at.at(0), at.at(1), at.at(2));
          }
        }
        prt::Display display;
        try {
          display.tone_map = prt::parse_tone_map(tone_map);
        } catch (const Error& e) {
          throw Error(std::string("tone_map: ") + e.what());
        }
        const bool auto_exposure = py::isinstance<py::str>(exposure) && exposure.cast<std::string>() == "auto";
        if (!auto_exposure) display.exposure = exposure_arg(exposure);
        const glm::dmat3 R = rotate.is_none() ? glm::dmat3(1.0) : to_rotation(rotate, "rotate");
        prt::Camera cam;
        std::optional<prt::Mesh> framed;
        if (pose && pose->kind != prt::Deform::Kind::None) {  // framed at rest and at its most deformed, as prt render
          framed.emplace();
          framed->positions = mesh.positions;
          const prt::Mesh posed = prt::deform_mesh(mesh, *pose);
          framed->positions.insert(framed->positions.end(), posed.positions.begin(), posed.positions.end());
        }
        cam = prt::framing_camera(framed ? *framed : mesh, fov, double(width) / height);
        if (!camera.is_none()) {
          py::object eye, target, up;
          if (py::isinstance<py::dict>(camera)) {
            const py::dict d = camera.cast<py::dict>();
            for (const auto& [k, v] : d) {
              const std::string key = py::str(k);
              if (key == "eye") eye = py::reinterpret_borrow<py::object>(v);
              else if (key == "target") target = py::reinterpret_borrow<py::object>(v);
              else if (key == "up") up = py::reinterpret_borrow<py::object>(v);
              else throw Error("camera: unknown key '" + key + "' (eye, target, up)");
            }
            if (!eye || !target) throw Error("camera: a dict needs 'eye' and 'target' (and 'up', default +Y)");
          } else {
            const DArray c = real_array<double>(camera, "camera");
            if (!(c.ndim() == 2 && (c.shape(0) == 2 || c.shape(0) == 3) && c.shape(1) == 3))
              throw Error("camera: expected (eye, target) or (eye, target, up), 3 numbers each, or a dict; got shape " +
                          shape_text(c));
            cam.eye = {c.at(0, 0), c.at(0, 1), c.at(0, 2)};
            cam.target = {c.at(1, 0), c.at(1, 1), c.at(1, 2)};
            cam.up = c.shape(0) == 3 ? glm::dvec3(c.at(2, 0), c.at(2, 1), c.at(2, 2)) : glm::dvec3(0, 1, 0);
          }
          const auto point = [](const py::object& o, const char* what) {
            const DArray a = real_array<double>(o, what);
            if (a.ndim() != 1 || a.shape(0) != 3) throw Error(std::string(what) + ": 3 numbers, got shape " + shape_text(a));
            return glm::dvec3(a.at(0), a.at(1), a.at(2));
          };
          if (eye) {
            cam.eye = point(eye, "camera eye");
            cam.target = point(target, "camera target");
            cam.up = up ? point(up, "camera up") : glm::dvec3(0, 1, 0);
          }
        }
        cam.fov_deg = fov;
        prt::EnvMap loaded;
        const prt::EnvMap* e = &map_argument(map, loaded);
        prt::require_finite(*e);
        std::vector<glm::dvec3> light, rotated;
        prt::Image img;
        std::vector<float> coverage;
        {
          py::gil_scoped_release release;
          light = prt::project(*e, file_bands);
          if (auto_exposure) display.exposure = prt::auto_exposure(file_bands >= 3 ? light : prt::project(*e, 3));
          std::fill(light.begin() + std::ptrdiff_t(std::size_t(bands) * bands), light.end(), glm::dvec3(0.0));
          rotated.resize(light.size());
          prt::sh::Rotation(file_bands, R).apply(light, rotated);
          img = GlWorker::get().run([&](prt::Renderer& r) {
            r.set_environment(*e);
            r.clear_probe_object();
            // The probe-lit object, as prt render's first frame (t = 0 of its path, or at object_at).
            std::optional<prt::ProbeObject> probe_object;
            const auto frame = [&] {
              if (volume) {
                try {
                  probe_object.emplace(*volume, *probe_mesh, *e, r, place);
                } catch (const prt::NoGlContext&) {
                  throw;
                } catch (const Error& x) {
                  throw Error(std::string("probes: ") + x.what());
                }
                probe_object->frame(r, R, 0.0);
              }
              prt::Image out = r.render(cam, width, height);
              if (alpha) coverage = r.coverage();
              r.clear_probe_object();
              return out;
            };
            if (is_wavelet) {  // as prt render: the CPU's relighting drawn as vertex colours, or Lambert
              r.set_mesh(mesh, wt->t.albedo, wt->t.vertex_colors);
              r.set_lighting(rotated);
              r.set_environment_rotation(R);
              if (shade == prt::Shading::Transfer) {
                prt::WaveletPlayback playback(wt->t, *e);
                playback.frame(r, R, terms, sel);
              } else {
                r.set_shading(prt::Shading::Lambert);
              }
              return frame();
            }
            try {
              if (is_lightmap)
                r.set_scene(*world, *lm);
              else if (is_zh)
                r.set_mesh(mesh, z->z);
              else if (p->compressed)
                r.set_mesh(mesh, *p->compressed);
              else
                r.set_mesh(mesh, p->t);
              r.set_band_limit(bands);
              r.set_shading(shade);
              if (glossy) r.set_glossy(gloss, specular, rho_d);
            } catch (const prt::NoGlContext&) {
              throw;
            } catch (const Error& x) {
              throw Error(source + ": " + x.what());
            }
            if (pose) r.set_pose(*pose, amount);
            r.set_lighting(rotated);
            r.set_environment_rotation(R);
            return frame();
          });
          prt::finish_frame(img.rgb, display, linear);
        }
        if (!alpha) return copy(img.rgb.data(), {py::ssize_t(img.height), py::ssize_t(img.width), 3});
        std::vector<float> rgba(coverage.size() * 4);
        for (std::size_t i = 0; i < coverage.size(); ++i) {
          std::copy_n(img.rgb.begin() + std::ptrdiff_t(i * 3), 3, rgba.begin() + std::ptrdiff_t(i * 4));
          rgba[i * 4 + 3] = coverage[i];
        }
        return copy(rgba.data(), {py::ssize_t(img.height), py::ssize_t(img.width), 4});
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("map"), py::kw_only(), py::arg("width") = 512,
      py::arg("height") = 512, py::arg("camera") = py::none(), py::arg("fov") = 40.0, py::arg("rotate") = py::none(),
      py::arg("exposure") = "auto", py::arg("tone_map") = "clamp", py::arg("linear") = false,
      py::arg("shading") = py::none(), py::arg("bands") = py::none(), py::arg("gloss") = 16.0,
      py::arg("specular") = 0.5, py::arg("diffuse") = py::none(), py::arg("deform") = py::none(),
      py::arg("amount") = 1.0, py::arg("terms") = 100, py::arg("selection") = "area", py::arg("alpha") = false,
      py::arg("probes") = py::none(), py::arg("object") = py::none(), py::arg("object_at") = py::none(),
      py::arg("object_size") = 0.0,
      "A frame as prt render draws it, headless (OpenGL 4.5 through EGL; one context per process, made on the "
      "first call on a thread of its own and reused): float32 (height, width, 3), row 0 at the top. The map is "
      "the background and the lighting (an EnvMap, a file name or an (H, W, 3) array), turned by rotate (a 3x3 "
      "matrix or yaw, pitch, roll degrees). camera: None (the framing camera: a three-quarter view from above that "
      "frames every vertex), (eye, target[, up]) or a dict; fov: vertical degrees. exposure: stops or 'auto' (a "
      "white diffuse surface facing the brightest light shows at 1). Values: the tone map's display values in "
      "[0, 1] (tone_map 'clamp', 'reinhard' or 'aces'; sRGB-encode them to show), or with linear=True the linear "
      "radiance times 2^exposure (what prt render writes to EXR). shading: the renderer's ('transfer', 'direct', "
      "'unshadowed', 'lambert', 'ao', 'bent', 'glossy', 'clusters'; default 'glossy' for a glossy transfer, "
      "else 'transfer'); bands: a band limit; gloss, specular, diffuse: a glossy transfer's lobe; deform "
      "('bend:ANGLE' or 'twist:ANGLE') and amount: a zonal-harmonic transfer's pose; terms and selection: a "
      "wavelet transfer's (relit on the CPU each frame, as prt render --terms --selection). A Lightmap draws its "
      "Scene (mesh=the Scene; shading 'transfer' or 'direct'). probes (a ProbeVolume of the scene drawn) and object "
      "(a Mesh): an object lit by the volume, as prt render --probes --object: object_size its bounding-box diagonal "
      "(0: twice the probe spacing), object_at its centre (None: the start of prt render's path). alpha=True: "
      "(height, width, 4), A = 1 where the model covers the pixel, 0 where the background shows (prt render "
      "--alpha). Raises prt.Error where no OpenGL 4.5 context can be had.");

  // ---- glTF export (prt/gltf.h; docs/FORMAT.md "glTF export") ----
  // What prt export writes for a transfer: its rows (a compressed one's
  // reconstructed) and the glTF options, COLOR_0 baked from `bake` as --bake.
  struct Export {
    prt::Transfer t;
    prt::GltfOptions opts;
  };
  const auto gltf_export = [](const PyTransfer& p, const prt::Mesh& mesh, const py::object& bake,
                              const py::object& rotate, const py::object& exposure) {
        prt::check_matches(p.t, mesh, p.source);
        if (bake.is_none() && (!rotate.is_none() || !exposure.is_none()))
          throw Error(std::string(rotate.is_none() ? "exposure" : "rotate") +
                      ": applies to the baked colours: give bake= (a map file) too");
        Export x{p.compressed ? prt::decompress(*p.compressed) : p.t, {}};
        const prt::Transfer& t = x.t;
        prt::GltfOptions& opts = x.opts;
        opts.transfer_source = p.source == "<computed>" || p.source == "<compressed>"
                                   ? std::string()
                                   : std::filesystem::path(p.source).filename().string();
        opts.generator = "prt " PRT_VERSION " (prt export)";
        if (!bake.is_none()) {
          // COLOR_0 as prt export --bake: the relit radiance times 2^exposure, clamped to [0, 1].
          if (!is_path(bake)) throw Error("bake: expected a map file (str or os.PathLike), as prt export --bake");
          const std::string map = path_of(bake, "bake");
          prt::EnvMap env = prt::load_envmap(map);
          prt::require_finite(env);
          std::vector<glm::dvec3> light = prt::project(env, t.bands);
          double euler[3] = {0, 0, 0};
          if (!rotate.is_none()) {
            const DArray r = real_array<double>(rotate, "rotate");
            if (r.ndim() != 1 || r.shape(0) != 3)
              throw Error("rotate: (yaw, pitch, roll) in degrees, as prt export --rotate (recorded in extras)");
            for (int k = 0; k < 3; ++k) euler[k] = r.data()[k];
            std::vector<glm::dvec3> turned(light.size());
            prt::sh::Rotation(t.bands, prt::sh::rotation_from_euler(euler[0], euler[1], euler[2])).apply(light, turned);
            light.swap(turned);
          }
          const std::vector<glm::vec3> rgb = prt::relight(t, mesh, light);
          prt::Display clamp{0.0, prt::ToneMap::Clamp};
          if (!exposure.is_none()) {
            if (py::isinstance<py::str>(exposure) && exposure.cast<std::string>() == "auto") {
              clamp.exposure = prt::auto_exposure(light);
            } else {
              clamp.exposure = exposure_arg(exposure);
            }
          }
          opts.colors.resize(rgb.size());
          for (std::size_t v = 0; v < rgb.size(); ++v)
            for (int c = 0; c < 3; ++c) {
              if (!std::isfinite(rgb[v][c]))
                throw Error("bake: the relit radiance of vertex " + std::to_string(v) + " overflows float; scale "
                            "the map down");
              opts.colors[v][c] = prt::tone_map(rgb[v][c], clamp);
            }
          opts.bake.map = std::filesystem::path(map).filename().string();
          for (int k = 0; k < 3; ++k) opts.bake.rotate[k] = euler[k];
          opts.bake.exposure = clamp.exposure;
        }
        return x;
  };

  m.def(
      "export_gltf",
      [gltf_export](const PyTransfer& p, const prt::Mesh& mesh, const py::object& path, const py::object& bake,
                    const py::object& rotate, const py::object& exposure) {
        const std::string out = path_of(path, "path");
        check_not_input("path", out, {{"transfer", p.source}, {"mesh", mesh.source},
                                      {"bake", is_path(bake) ? path_of(bake, "bake") : std::string()}});
        const Export x = gltf_export(p, mesh, bake, rotate, exposure);
        py::gil_scoped_release release;
        prt::write_gltf(out, mesh, x.t, x.opts);
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("path"), py::kw_only(), py::arg("bake") = py::none(),
      py::arg("rotate") = py::none(), py::arg("exposure") = py::none(),
      "Writes the mesh and its SH transfer as glTF 2.0 (.glb binary, .gltf JSON; docs/FORMAT.md \"glTF "
      "export\") to `path`, as prt export MESH T -o FILE does, the same bytes: the transfer rows as vertex attributes "
      "_PRT_T0, ... (a compressed transfer's reconstructed rows; a glossy one's diffuse part), described in "
      "asset.extras.prt. bake: a map file whose relit radiance becomes COLOR_0 (turned by rotate, yaw, pitch, "
      "roll degrees; times 2^exposure, stops or 'auto', default 0; clamped to [0, 1]), as --bake.");

  m.def(
      "export_web",
      [gltf_export](const PyTransfer& p, const prt::Mesh& mesh, const py::object& dir, const py::object& env,
                    const py::object& camera, double fov, const py::object& rotate, const py::object& exposure,
                    const std::string& tone_map, bool turn, bool force, const py::object& bake) {
        // The model: the glTF prt export writes (its bake recorded with the page's rotate and exposure, as the
        // command's --bake, --rotate and --exposure serve both).
        const Export x = gltf_export(p, mesh, bake, bake.is_none() ? py::none() : rotate,
                                     bake.is_none() ? py::none() : exposure);
        prt::WebPage w;
        w.dir = path_of(dir, "dir");
        check_not_input("dir", w.dir, {{"transfer", p.source}, {"mesh", mesh.source},
                                       {"bake", is_path(bake) ? path_of(bake, "bake") : std::string()},
                                       {"env", is_path(env) ? path_of(env, "env") : std::string()}});
        w.force = force;
        w.turn = turn;
        w.maps = prt::web_maps(env.is_none() ? std::string() : path_of(env, "env"), w.initial);
        check_fov(fov);
        w.camera = prt::framing_camera(mesh, fov, 1.0);
        if (!camera.is_none()) {
          const DArray c = real_array<double>(camera, "camera");
          if (!(c.ndim() == 2 && (c.shape(0) == 2 || c.shape(0) == 3) && c.shape(1) == 3))
            throw Error("camera: expected (eye, target) or (eye, target, up), 3 numbers each; got shape " + shape_text(c));
          w.camera.eye = {c.at(0, 0), c.at(0, 1), c.at(0, 2)};
          w.camera.target = {c.at(1, 0), c.at(1, 1), c.at(1, 2)};
          w.camera.up = c.shape(0) == 3 ? glm::dvec3(c.at(2, 0), c.at(2, 1), c.at(2, 2)) : glm::dvec3(0, 1, 0);
        }
        w.camera.fov_deg = fov;
        if (!rotate.is_none()) {
          const DArray r = real_array<double>(rotate, "rotate");
          if (r.ndim() != 1 || r.shape(0) != 3) throw Error("rotate: (yaw, pitch, roll) in degrees");
          for (int k = 0; k < 3; ++k) w.rotate[k] = r.data()[k];
        }
        try {
          w.display.tone_map = prt::parse_tone_map(tone_map);
        } catch (const Error& e) {
          throw Error(std::string("tone_map: ") + e.what());
        }
        if (exposure.is_none() || (py::isinstance<py::str>(exposure) && exposure.cast<std::string>() == "auto")) {
          w.display.exposure = prt::auto_exposure(prt::project(prt::load_envmap(w.initial), 3));
        } else {
          w.display.exposure = exposure_arg(exposure);
        }
        py::gil_scoped_release release;
        std::unique_ptr<prt::StagedPage> page = prt::stage_web_page(
            w, x.t.bands, [&](const std::string& path) { prt::write_gltf(path, mesh, x.t, x.opts); }, {}, true);
        page->commit();
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("dir"), py::kw_only(), py::arg("env") = py::none(),
      py::arg("camera") = py::none(), py::arg("fov") = 40.0, py::arg("rotate") = py::none(),
      py::arg("exposure") = py::none(), py::arg("tone_map") = "clamp", py::arg("turn") = false, py::arg("force") = false,
      py::arg("bake") = py::none(),
      "Writes the relighting web page (docs/WEB.md) into `dir`, as prt export MESH T --web DIR does (the same files): index.html and its scripts, model.glb, lighting.json (every map's SH), maps/. Written whole or not at all.\n"
      "\n"
      "Arguments (prt export's option in brackets):\n"
      "  transfer: a Transfer; mesh: its Mesh; dir: the directory [--web].\n"
      "  env: the map shown first, a file or a bundled map's name (None: the bundled maps only) [--env].\n"
      "  camera: None (the framing camera) or (eye, target[, up]) [--camera]; fov: vertical degrees [--fov].\n"
      "  rotate: (yaw, pitch, roll) degrees [--rotate]; exposure: stops or 'auto' (None: 'auto' for the page, 0 for a bake) [--exposure].\n"
      "  tone_map: 'clamp', 'reinhard' or 'aces' [--tonemap]; turn: start with the environment turning [--turn].\n"
      "  force: replace an existing non-empty dir [--force]; bake: a map file: COLOR_0 in the model, as export_gltf [--bake].");

  // ---- info and verify ----
  m.def(
      "info",
      [](const py::object& path) {
        const std::string p = path_of(path, "path");
        std::string text;
        {
          py::gil_scoped_release release;
          text = prt::file_info_json(p);
        }
        return py::module_::import("json").attr("loads")(text);
      },
      py::arg("path"),
      "What the prt file at `path` holds (any transfer file, compressed, wavelet, zonal-harmonic, lightmap or probe volume), validated completely: the dict prt info --json prints (docs/FORMAT.md).");

  m.def(
      "verify",
      [](int bands_max, int float_bands, py::object progress) {
        if (bands_max < 3 || bands_max > prt::sh::kMaxBands)
          throw Error("bands_max: must be 3 to " + std::to_string(prt::sh::kMaxBands));
        if (float_bands < 1 || float_bands > prt::sh::kMaxBands)
          throw Error("float_bands: must be 1 to " + std::to_string(prt::sh::kMaxBands));
        prt::VerifyOptions o;
        o.bands_max = bands_max;
        o.float_bands = float_bands;
        const std::vector<prt::CheckResult> checks = run_released(std::move(progress), [&](const prt::Progress& pr) {
          std::size_t done = 0;
          return prt::run_verify(o, [&](const prt::CheckResult&) {
            if (pr && !pr(++done, 0, "checks")) throw Error("cancelled");
          });
        });
        py::list out;
        for (const prt::CheckResult& c : checks)
          out.append(py::dict(py::arg("group") = c.group, py::arg("name") = c.name, py::arg("error") = c.error,
                              py::arg("tolerance") = c.tolerance, py::arg("why") = c.why,
                              py::arg("passed") = c.pass()));
        return out;
      },
      py::kw_only(), py::arg("bands_max") = 32, py::arg("float_bands") = 16, py::arg("progress") = py::none(),
      "prt verify's checks of the SH numerics against exact answers, as records. Releases the GIL.\n"
      "\n"
      "Arguments:\n"
      "  bands_max: the highest band checked [--bands-max]; float_bands: the bands checked in float as well [--float-bands].\n"
      "  progress: as precompute's.\n"
      "\n"
      "Returns a list of dicts: group, name (what was measured), error, tolerance, why (why the tolerance is what it is), passed.");

  // ---- compression (prt compress; docs/COMPRESSION.md) ----
  // prt compress --rotations and --eyes's ranges (make_error_distribution refuses the rest too).
  const auto check_measure = [](int rotations, int eyes) {
    if (rotations < 1 || rotations > prt::kMaxErrorRotations)
      throw Error("rotations: must be 1 to " + std::to_string(prt::kMaxErrorRotations) + ", got " +
                  std::to_string(rotations));
    if (eyes < 1 || eyes > prt::kMaxErrorEyes)
      throw Error("eyes: must be 1 to " + std::to_string(prt::kMaxErrorEyes) + ", got " + std::to_string(eyes));
  };
  // The distribution prt compress measures under, from the keyword arguments.
  const auto distribution = [check_measure](const prt::Transfer& t, const py::object& envs, const py::object& spectra,
                               bool own_spectra, bool sun, int rotations, int eyes) {
    prt::DistributionSpec spec;
    const auto paths = [](const py::object& list, const char* what) {
      std::vector<std::string> out;
      if (list.is_none()) return out;
      if (is_path(list)) return std::vector<std::string>{path_of(list, what)};
      for (const py::handle item : list) {
        if (!is_path(item)) throw Error(std::string(what) + ": expected map files (str or os.PathLike)");
        out.push_back(path_of(item, what));
      }
      return out;
    };
    spec.maps = paths(envs, "envs");
    spec.spectra = paths(spectra, "spectra");
    if (own_spectra && !spec.spectra.empty())
      throw Error("own_spectra: leaves the maps' spectra as they are; spectra= adds others': give one of them");
    spec.own_spectra = own_spectra;
    spec.sun = sun;
    check_measure(rotations, eyes);
    spec.rotations = rotations;
    spec.eyes = eyes;
    return prt::make_error_distribution(spec, t.bands);
  };
  const auto stats_dict = [](const prt::ErrorStats& e) {
    py::dict d;
    d["mean"] = e.mean;
    d["p95"] = e.p95;
    d["max"] = e.max;
    d["samples"] = e.samples;
    d["bound"] = e.bound;
    return d;
  };

  m.def(
      "compress",
      [distribution, check_measure](const PyTransfer& p, int clusters, int pca, int glossy_clusters, int glossy_pca, int weights,
                     int iterations, std::uint64_t seed, const py::object& target_error, const py::object& mesh,
                     const py::object& envs, const py::object& spectra, bool own_spectra, bool sun, int rotations,
                     int eyes, const std::string& statistic, const std::string& metric, bool exhaustive,
                     py::object progress) {
        if (p.compressed)
          throw Error(p.source + ": already compressed; compress the uncompressed transfer precompute made");
        if (weights != 16 && weights != 32) throw Error("weights: 16 or 32 (bits per stored weight)");
        if (statistic != "p95" && statistic != "mean") throw Error("statistic: 'p95' or 'mean', got '" + statistic + "'");
        if (metric != "band" && metric != "plain") throw Error("metric: 'band' or 'plain', got '" + metric + "'");
        check_measure(rotations, eyes);  // whether or not a target uses them, as the command's options
        PyTransfer out;
        out.source = "<compressed>";
        if (target_error.is_none()) {
          if (!p.t.glossy && (glossy_clusters != 128 || glossy_pca != 8))
            throw Error(p.source + ": glossy_clusters and glossy_pca need glossy matrices, which this transfer does "
                        "not have");
          prt::CompressOptions o{.clusters = clusters, .vectors = pca, .glossy_clusters = glossy_clusters,
                                 .glossy_vectors = glossy_pca, .iterations = iterations, .seed = seed,
                                 .weight_bits = weights, .progress = {}};
          out.compressed = run_released(std::move(progress), [&](const prt::Progress& pr) {
            prt::CompressOptions oo = o;
            oo.progress = pr;
            return prt::compress_transfer(p.t, oo);
          });
        } else {
          if (mesh.is_none()) throw Error("mesh: target_error measures the relit error on the mesh: give mesh=");
          if (!py::isinstance<prt::Mesh>(mesh))
            throw Error("mesh: expected a prt.Mesh (load_mesh, make_mesh), got " +
                        std::string(py::str(py::type::of(mesh).attr("__name__"))));
          const DArray te = real_array<double>(target_error, "target_error");
          if (te.ndim() != 0) throw Error("target_error: a relative RMS error in (0, 1), a number");
          const double target = te.data()[0];
          if (!(target > 0 && target < 1))
            throw Error("target_error: a relative RMS error in (0, 1), got " + number_text(target));
          const auto& target_mesh = mesh.cast<const prt::Mesh&>();
          prt::check_matches(p.t, target_mesh, p.source);
          const prt::ErrorDistribution d = distribution(p.t, envs, spectra, own_spectra, sun, rotations, eyes);
          prt::ChoiceOptions o;
          o.target = target;
          o.statistic = statistic == "mean" ? prt::ErrorStatistic::Mean : prt::ErrorStatistic::P95;
          o.metric = metric == "plain" ? prt::CompressionMetric::Plain : prt::CompressionMetric::Band;
          o.weight_bits = weights;
          o.iterations = iterations;
          o.seed = seed;
          o.exhaustive = exhaustive;
          out.compressed = run_released(std::move(progress), [&](const prt::Progress& pr) {
            prt::ChoiceOptions oo = o;
            oo.progress = pr;
            return prt::choose_compression(p.t, target_mesh, d, oo).compressed;
          });
        }
        out.t = prt::decompress(*out.compressed);
        return out;
      },
      py::arg("transfer"), py::kw_only(), py::arg("clusters") = 256, py::arg("pca") = 8,
      py::arg("glossy_clusters") = 128, py::arg("glossy_pca") = 8, py::arg("weights") = 16, py::arg("iterations") = 20,
      py::arg("seed") = 1, py::arg("target_error") = py::none(), py::arg("mesh") = py::none(),
      py::arg("envs") = py::none(), py::arg("spectra") = py::none(), py::arg("own_spectra") = false,
      py::arg("sun") = true, py::arg("rotations") = 24, py::arg("eyes") = 32, py::arg("statistic") = "p95",
      py::arg("metric") = "band", py::arg("exhaustive") = false, py::arg("progress") = py::none(),
      "Clustered PCA of a transfer (Sloan et al. 2003), as prt compress does (the same bits): .compressed is True, relight() uses its per-cluster products, .write() writes the file prt compress writes. docs/COMPRESSION.md. Releases the GIL.\n"
      "\n"
      "Arguments (prt compress's option in brackets):\n"
      "  transfer: a Transfer (not compressed).\n"
      "  clusters, pca: K clusters of N principal vectors [--clusters, --pca]; glossy_clusters, glossy_pca: the glossy matrices' own [--glossy-clusters, --glossy-pca].\n"
      "  weights: 16 or 32 bits per weight [--weights].\n"
      "  iterations: k-means rounds [--iterations]; seed [--seed].\n"
      "  target_error: instead of sizes, the smallest K x N whose relit error meets it (relative RMS, with mesh=) [--target-error]:\n"
      "    statistic 'p95' or 'mean'; metric 'band' or 'plain'; exhaustive: try every size, not the search [--exhaustive];\n"
      "    envs (map files; None: the bundled maps) under `rotations` rotations taking on the spectra of `spectra`\n"
      "    (None: the bundled maps'; own_spectra=True: none), the sun unless sun=False, and glossy: `eyes` views.\n"
      "  mesh: the Mesh the transfer was computed for (target_error).\n"
      "  progress: as precompute's.\n"
      "\n"
      "Returns a Transfer (compressed).");

  m.def(
      "compression_error",
      [distribution, stats_dict](const PyTransfer& p, const PyTransfer& c, const prt::Mesh& mesh, const py::object& envs,
                                 int rotations, int eyes) {
        if (p.compressed) throw Error("transfer: " + p.source + " is compressed; give the uncompressed one it came from");
        if (!c.compressed) throw Error("compressed: " + c.source + " is not compressed (compress() or prt compress)");
        const prt::Transfer& ct = c.compressed->transfer;
        if (ct.vertices != p.t.vertices || ct.bands != p.t.bands || ct.glossy != p.t.glossy ||
            c.compressed->coeffs.rows() != p.t.coeffs.size() / std::max<std::size_t>(p.t.stride(), 1))
          throw Error("compressed: " + c.source + " is not a compression of " + p.source +
                      " (other vertices, bands or signals)");
        prt::check_matches(p.t, mesh, p.source);
        const prt::ErrorDistribution d = distribution(p.t, envs, py::none(), true, false, rotations, eyes);
        prt::ErrorStats e;
        {
          py::gil_scoped_release release;
          e = prt::CompressionErrorMeter(p.t, mesh, d)(*c.compressed, true);
        }
        return stats_dict(e);
      },
      py::arg("transfer"), py::arg("compressed"), py::arg("mesh"), py::kw_only(), py::arg("envs") = py::none(),
      py::arg("rotations") = 24, py::arg("eyes") = 32,
      "The relit error of a compressed transfer against the one it came from, as prt compress --measure.\n"
      "\n"
      "Arguments:\n"
      "  transfer: the Transfer it came from; compressed: the compressed Transfer; mesh: the Mesh both were computed for.\n"
      "  envs: map files (None: the bundled ones), each under `rotations` rotations; eyes: glossy views per rotation.\n"
      "\n"
      "Returns a dict: mean, p95, max (relative RMS over the vertices, per sample), samples, bound (the transfer-space bound no lighting exceeds).");

  // The C++ call relight() wraps, timed here (median seconds a call over
  // `repeats`), so a benchmark compares the module's call with it in one
  // process (bench/python_relight_overhead.py). Not part of the API.
  m.def(
      "_time_relight",
      [](const PyTransfer& p, const prt::Mesh& mesh, const py::object& lighting, int repeats) {
        const std::vector<glm::dvec3> light = to_coeffs(lighting, "lighting");
        if (repeats < 1) throw Error("repeats: must be at least 1");
        prt::check_matches(p.t, mesh, p.source);
        std::vector<double> t(static_cast<std::size_t>(repeats));
        py::gil_scoped_release release;
        for (double& s : t) {
          const auto t0 = std::chrono::steady_clock::now();
          const std::vector<glm::vec3> rgb = prt::relight(p.t, mesh, light);
          s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          if (rgb.empty()) s = 0;  // keeps the call
        }
        std::sort(t.begin(), t.end());
        return t[t.size() / 2];
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("lighting"), py::arg("repeats") = 200);

  // ---- wavelet transfer (prt/wavelet_transfer.h, docs/WAVELETS.md) ----
  py::class_<PyWavelet>(m, "WaveletTransfer",
                        "An all-frequency shadowed transfer (Ng, Ramamoorthi & Hanrahan 2003): per vertex, the "
                        "largest Haar wavelet coefficients of its visibility times cosine on a cube map")
      .def_property_readonly("cube_res", [](const PyWavelet& p) { return p.t.cube_res; }, "The cube's face size r")
      .def_property_readonly("coefficient_count", [](const PyWavelet& p) { return p.t.coeff_count(); }, "6 r^2")
      .def_property_readonly("vertices", [](const PyWavelet& p) { return p.t.vertices; })
      .def_property_readonly("threshold", [](const PyWavelet& p) { return p.t.threshold; })
      .def_property_readonly("albedo", [](const PyWavelet& p) { return py::make_tuple(p.t.albedo.x, p.t.albedo.y, p.t.albedo.z); })
      .def_property_readonly("vertex_colors", [](const PyWavelet& p) { return p.t.vertex_colors; })
      .def_property_readonly("mesh_hash", [](const PyWavelet& p) { return p.t.mesh_hash; })
      .def_property_readonly("kept", [](const PyWavelet& p) { return p.t.kept(); }, "Coefficients kept, all vertices")
      .def_property_readonly("kept_fraction", [](const PyWavelet& p) { return p.t.kept_fraction(); },
                             "Kept coefficients over vertices x 6 r^2")
      .def_property_readonly("nbytes", [](const PyWavelet& p) { return p.t.bytes(); })
      .def_property_readonly("source", [](const PyWavelet& p) { return p.source; })
      .def(
          "coefficients",
          [](const PyWavelet& p, std::int64_t v) {
            if (v < 0 || std::uint64_t(v) >= p.t.vertices)
              throw Error("vertex: " + std::to_string(v) + " is out of range (" + std::to_string(p.t.vertices) +
                          " vertices)");
            const std::vector<float> c = prt::wavelet_vertex_coefficients(p.t, std::size_t(v));
            return copy(c.data(), {py::ssize_t(c.size())});
          },
          py::arg("vertex"),
          "float32 (6 r^2,): the vertex's dequantised Haar coefficients (zeros where dropped), in prt/wavelet.h's "
          "index order")
      .def("write", [](const PyWavelet& p, const py::object& path) { prt::write_wavelet_transfer(path_of(path, "path"), p.t); },
           py::arg("path"), "Writes the file to `path` (atomically) as prt precompute --basis wavelet does (docs/FORMAT.md).")
      .def("describe", [](const PyWavelet& p) { return prt::describe_transfer(p.t); }, "prt info's text")
      .def("__str__", [](const PyWavelet& p) { return prt::describe_transfer(p.t); })
      .def("__repr__", [](const PyWavelet& p) {
        return "<prt.WaveletTransfer " + p.source + ": cube " + std::to_string(p.t.cube_res) + ", " +
               std::to_string(p.t.vertices) + " vertices, " + std::to_string(p.t.kept()) + " coefficients kept>";
      });

  m.def(
      "read_wavelet",
      [](const py::object& path) {
        PyWavelet p;
        p.source = path_of(path, "path");
        p.t = prt::read_wavelet_transfer(p.source);
        return p;
      },
      py::arg("path"), "Reads the wavelet transfer file at `path` (prt precompute --basis wavelet). Returns a WaveletTransfer.");

  m.def(
      "relight",
      [](const PyWavelet& p, const prt::Mesh& mesh, const py::object& map, int terms, const std::string& selection,
         const py::object& rotate) {
        check_terms(terms);
        const prt::wavelet::Selection sel = [&] {
          try {
            return prt::wavelet::parse_selection(selection);
          } catch (const Error& e) {
            throw Error(std::string("selection: ") + e.what());
          }
        }();
        if (py::isinstance<py::array>(map) && !py::isinstance<prt::EnvMap>(map)) {
          // SH coefficients are not a map: say so rather than read them as pixels.
          const py::array a = map.cast<py::array>();
          if (a.ndim() == 2 && a.shape(1) == 3)
            throw Error("map: a wavelet transfer relights from the map itself (an EnvMap, a file name or an (H, W, "
                        "3) array), not from SH coefficients");
        }
        const glm::dmat3 R = rotate.is_none() ? glm::dmat3(1.0) : to_rotation(rotate, "rotate");
        prt::check_matches(p.t, mesh, p.source);
        prt::EnvMap loaded;
        const prt::EnvMap* e = &map_argument(map, loaded);
        prt::require_finite(*e);
        std::vector<glm::vec3> rgb;
        {
          py::gil_scoped_release release;
          prt::wavelet::FrameLighting lighting(*e, p.t.cube_res);
          lighting.update(R, terms, sel);
          prt::wavelet_relight(p.t, lighting.coefficients().data(), lighting.terms(), rgb);
        }
        return vec3s(rgb);
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("map"), py::kw_only(), py::arg("terms") = 100,
      py::arg("selection") = "area", py::arg("rotate") = py::none(),
      "A wavelet transfer's outgoing radiance under a map, as prt relight --terms K --selection S [--rotate]: the map resampled to the cube (rotated: light from d arrives from R d), Haar-transformed, its `terms` largest coefficients kept, each vertex's sum over them.\n"
      "\n"
      "Arguments:\n"
      "  transfer: a WaveletTransfer; mesh: the Mesh it was computed for.\n"
      "  map: an EnvMap, a file name or an (H, W, 3) array.\n"
      "  terms: K, the coefficients kept (100) [--terms].\n"
      "  selection: 'area' (|c| times its support's area, Ng et al. 2003) or 'magnitude' (|c|) [--selection].\n"
      "  rotate: a 3x3 rotation or (yaw, pitch, roll) degrees [--rotate].\n"
      "\n"
      "Returns float32 (V, 3).");

  // ---- local deformable PRT (prt/zh_transfer.h, docs/LDPRT.md) ----
  py::class_<PyZhTransfer>(m, "ZhTransfer",
                           "A local deformable transfer (prt/zh_transfer.h): per stored vertex, K zonal-harmonic "
                           "lobes with axes in the vertex's rest frame, which turn with the surface in a pose")
      .def_property_readonly("bands", [](const PyZhTransfer& p) { return p.z.bands; }, "SH bands of each lobe (posed: bands^2 coefficients)")
      .def_property_readonly("lobes", [](const PyZhTransfer& p) { return p.z.lobes; })
      .def_property_readonly("channels", [](const PyZhTransfer& p) { return p.z.channels; })
      .def_property_readonly("mode", [](const PyZhTransfer& p) { return std::string(prt::transfer_mode_name(p.z.mode)); })
      .def_property_readonly("bounces", [](const PyZhTransfer& p) { return p.z.bounces; })
      .def_property_readonly("samples", [](const PyZhTransfer& p) { return p.z.samples; })
      .def_property_readonly("albedo", [](const PyZhTransfer& p) { return py::make_tuple(p.z.albedo.x, p.z.albedo.y, p.z.albedo.z); })
      .def_property_readonly("vertex_colors", [](const PyZhTransfer& p) { return p.z.vertex_colors; })
      .def_property_readonly("seed", [](const PyZhTransfer& p) { return p.z.seed; })
      .def_property_readonly("vertices", [](const PyZhTransfer& p) { return p.z.vertices; })
      .def_property_readonly("fit_error", [](const PyZhTransfer& p) { return p.z.fit_error; },
                             "Relative error of the fit over the stored rows, in the SH transfer's space")
      .def_property_readonly("analytic_vertices", [](const PyZhTransfer& p) { return p.z.analytic_vertices(); })
      .def_property_readonly("stored_vertices", [](const PyZhTransfer& p) { return p.z.stored_vertices(); })
      .def_property_readonly("mesh_hash", [](const PyZhTransfer& p) { return p.z.mesh_hash; },
                             "Mesh.hash of the rest pose")
      .def_property_readonly("topology_hash", [](const PyZhTransfer& p) { return p.z.topology_hash; },
                             "XXH3-64 of the vertex count and triangles: what a pose must share with the rest pose")
      .def_property_readonly("source", [](const PyZhTransfer& p) { return p.source; })
      .def_property_readonly(
          "analytic",
          [](const PyZhTransfer& p) {
            py::array_t<bool> a(py::ssize_t(p.z.vertices));
            for (std::size_t v = 0; v < p.z.vertices; ++v) a.mutable_at(v) = p.z.is_analytic(v);
            return a;
          },
          "bool (V,): vertices that store no lobes (unoccluded: the clamped cosine about the posed normal)")
      .def_property_readonly(
          "slots",
          [](const PyZhTransfer& p) {
            py::array_t<std::int64_t> a(py::ssize_t(p.z.vertices));
            for (std::size_t v = 0; v < p.z.vertices; ++v)
              a.mutable_at(v) = p.z.is_analytic(v) ? -1 : std::int64_t(p.z.row(v));
            return a;
          },
          "int64 (V,): each vertex's row in axes and coeffs, or -1 when analytic")
      .def_property_readonly(
          "axes",
          [](py::object self) {
            const auto& p = self.cast<const PyZhTransfer&>();
            return view(p.z.axes.empty() ? nullptr : p.z.axes.data(),
                        {py::ssize_t(p.z.stored_vertices()), p.z.lobes, 3}, self);
          },
          "float32 (stored vertices, lobes, 3): unit lobe axes in each vertex's rest frame (x tangent, y "
          "bitangent, z normal), shared by the channels; read-only")
      .def_property_readonly(
          "coeffs",
          [](py::object self) {
            const auto& p = self.cast<const PyZhTransfer&>();
            return view(p.z.coeffs.empty() ? nullptr : p.z.coeffs.data(),
                        {py::ssize_t(p.z.stored_vertices()), p.z.channels, p.z.lobes, p.z.bands}, self);
          },
          "float32 (stored vertices, channels, lobes, bands): each lobe's zonal coefficients g_il; read-only")
      .def_property_readonly(
          "tangent_rules",
          [](const PyZhTransfer& p) {
            const std::size_t V = p.z.tangents.size();
            py::array_t<std::uint32_t> vertices({py::ssize_t(V), py::ssize_t(2)});
            py::array_t<float> weights({py::ssize_t(V), py::ssize_t(2)});
            for (std::size_t v = 0; v < V; ++v) {
              vertices.mutable_at(v, 0) = p.z.tangents[v].a, vertices.mutable_at(v, 1) = p.z.tangents[v].b;
              weights.mutable_at(v, 0) = p.z.tangents[v].wa, weights.mutable_at(v, 1) = p.z.tangents[v].wb;
            }
            return py::make_tuple(vertices, weights);
          },
          "(uint32 (V, 2) neighbours a, b; float32 (V, 2) weights wa, wb): each vertex's tangent in any pose is the "
          "part of wa (p_a - p) + wb (p_b - p) perpendicular to its normal (docs/CONVENTIONS.md, \"Vertex frames\": "
          "a = b the edge rule, a != b the UV tangent, a = b = the vertex none)")
      .def("write", [](const PyZhTransfer& p, const py::object& path) { prt::write_zh_transfer(path_of(path, "path"), p.z); },
           py::arg("path"), "Writes the file to `path` (atomically) as prt precompute --basis zh does (docs/FORMAT.md).")
      .def("describe", [](const PyZhTransfer& p) { return prt::describe_transfer(p.z); },
           "prt info's text: lobes, bands, channels, mode, vertices, fit error, sizes, hashes")
      .def("__str__", [](const PyZhTransfer& p) { return prt::describe_transfer(p.z); })
      .def("__repr__", [](const PyZhTransfer& p) {
        return "<prt.ZhTransfer " + p.source + ": " + std::to_string(p.z.lobes) + " lobes x " +
               std::to_string(p.z.bands) + " bands, " + std::string(prt::transfer_mode_name(p.z.mode)) + ", " +
               std::to_string(p.z.channels) + " channel(s), " + std::to_string(p.z.vertices) + " vertices>";
      });

  m.def(
      "read_zh",
      [](const py::object& path) {
        PyZhTransfer p;
        p.source = path_of(path, "path");
        p.z = prt::read_zh_transfer(p.source);
        return p;
      },
      py::arg("path"), "Reads the zonal-harmonic (local deformable) transfer file at `path` (prt precompute --basis zh). Returns a ZhTransfer.");

  m.def(
      "fit_zh",
      [](const PyTransfer& p, const prt::Mesh& mesh, int lobes, int rounds, int threads, py::object progress) {
        prt::check_matches(p.t, mesh, p.source);
        prt::ZhFitOptions o;
        o.lobes = lobes;
        o.rounds = rounds;
        o.threads = threads_arg(threads);
        PyZhTransfer z;
        z.z = run_released(std::move(progress),
                           [&](const prt::Progress& pr) { return prt::fit_zh_transfer(p.t, mesh, o, pr); });
        return z;
      },
      py::arg("transfer"), py::arg("mesh"), py::kw_only(), py::arg("lobes") = 4, py::arg("rounds") = 12,
      py::arg("threads") = 0, py::arg("progress") = py::none(),
      "Fits zonal-harmonic lobes to every stored row of an SH transfer computed for `mesh` (the rest pose), as prt precompute --basis zh --lobes K does after its SH pass (the same bits, for any `threads`). Refuses a glossy transfer and more than 16 bands. Releases the GIL.\n"
      "\n"
      "Arguments (prt precompute's option in brackets):\n"
      "  transfer: a Transfer; mesh: its Mesh (with uvs=True for UV tangents).\n"
      "  lobes: K, 1 to 8 (4) [--lobes]; rounds: the fit's refinement rounds (12).\n"
      "  threads; progress: as precompute's. The frames' tangent: the UV rule where the mesh has corner UVs, else the edge rule (--tangent).\n"
      "\n"
      "Returns a ZhTransfer.");

  m.def(
      "deform",
      [](const prt::Mesh& mesh, const std::string& deformation, double amount) {
        const prt::Deform d = prt::parse_deform(deformation);
        if (!std::isfinite(amount)) throw Error("amount: must be finite (0: the rest pose, 1: the whole angle)");
        py::gil_scoped_release release;
        return prt::deform_mesh(mesh, d, amount);
      },
      py::arg("mesh"), py::arg("deformation"), py::arg("amount") = 1.0,
      "A pose of `mesh`, as prt relight --deform makes it. Same vertices and triangles; new positions and normals.\n"
      "\n"
      "Arguments:\n"
      "  mesh: the rest Mesh.\n"
      "  deformation: 'bend:ANGLE' (its y extent bent into an arc of ANGLE degrees towards +x) or 'twist:ANGLE' (about y) [--deform].\n"
      "  amount: the fraction of the angle (1: all of it).\n"
      "\n"
      "Returns a Mesh.");

  m.def(
      "pose",
      [](const PyZhTransfer& p, const prt::Mesh& posed, bool report) -> py::object {
        prt::check_pose(p.z, posed, p.source);
        prt::PoseReport r;
        std::vector<float> rows;
        {
          py::gil_scoped_release release;
          rows = prt::posed_transfer(p.z, posed, &r);
        }
        py::object a = copy(rows.data(), {py::ssize_t(p.z.vertices), p.z.channels, py::ssize_t(p.z.bands) * p.z.bands});
        if (report) return py::make_tuple(a, pose_report(r));
        return a;
      },
      py::arg("transfer"), py::arg("mesh"), py::kw_only(), py::arg("report") = false,
      "float32 (V, channels, bands^2): every vertex's SH transfer in the pose `mesh` (the rest mesh's "
      "vertices and triangles, moved: deform(), or any mesh with the same topology), each vertex's lobes turned "
      "into its posed frame. report=True: (rows, {'no_frame': n, 'normal_only': n, 'uv': n}), the vertices "
      "without a frame in the pose (zero transfer), those whose frame came from the normal alone, and those whose "
      "tangent is the UV tangent.");

  m.def(
      "relight",
      [](const PyZhTransfer& p, const prt::Mesh& posed, const py::object& lighting, bool direct) {
        const std::vector<glm::dvec3> light = to_coeffs(lighting, "lighting");
        const std::size_t need = std::size_t(p.z.bands) * p.z.bands;
        if (light.size() < need)
          throw Error("lighting: " + std::to_string(light.size()) + " coefficients; " + p.source + " has " +
                      std::to_string(p.z.bands) + " bands and needs " + std::to_string(need));
        if (direct) throw Error(p.source + ": direct=True: a zonal-harmonic transfer holds lobes of one transfer (no direct part)");
        prt::check_pose(p.z, posed, p.source);
        std::vector<glm::vec3> rgb;
        {
          py::gil_scoped_release release;
          const prt::Transfer t = prt::posed_as_transfer(p.z, posed);
          rgb = prt::relight(t, posed, light);
        }
        return vec3s(rgb);
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("lighting"), py::kw_only(), py::arg("direct") = false,
      "A zonal-harmonic transfer's outgoing radiance in the pose `mesh`, as prt relight POSED f.prt ENV [--deform ...].\n"
      "\n"
      "Arguments:\n"
      "  transfer: a ZhTransfer (fit_zh, read_zh); mesh: the rest mesh or any pose of it (deform, pose).\n"
      "  lighting: coefficients (n*n, 3) (project()); direct: the direct part only [--direct].\n"
      "\n"
      "Returns float32 (V, 3).");

  // ---- the reference ----
  m.def(
      "reference",
      [](const prt::Mesh& mesh, const py::object& map, const std::string& mode, int bounces, const py::object& albedo,
         bool vertex_colors, int samples, std::uint64_t seed, double offset, const py::object& rotate, int threads,
         py::object progress) {
        prt::ReferenceOptions o;
        o.mode = prt::parse_transfer_mode(mode);
        o.bounces = bounces;
        o.albedo = to_albedo(albedo);
        o.vertex_colors = vertex_colors;
        o.samples = samples;
        o.seed = seed;
        o.offset = offset;
        if (!rotate.is_none()) o.rotation = to_rotation(rotate, "rotate");
        prt::EnvMap loaded;
        const prt::EnvMap* e = &map_argument(map, loaded);
        prt::require_finite(*e);
        if (e->is_cube()) throw Error(e->source + ": the reference needs a lat-long (2:1) map, not " + e->source_layout);
        const auto limit = limit_threads(threads);
        const prt::ReferenceResult r = run_released(
            std::move(progress), [&](const prt::Progress& pr) { return prt::render_reference(mesh, *e, o, pr); });
        return py::make_tuple(vec3s(r.radiance), vec3s(r.std_error));
      },
      py::arg("mesh"), py::arg("map"), py::kw_only(), py::arg("mode") = "shadowed", py::arg("bounces") = 1,
      py::arg("albedo") = 0.8, py::arg("vertex_colors") = false, py::arg("samples") = 4096, py::arg("seed") = 1,
      py::arg("offset") = 0.0, py::arg("rotate") = py::none(), py::arg("threads") = 0,
      py::arg("progress") = py::none(),
      "Monte Carlo ground truth, as prt reference computes it (the same defaults, the same bits): every vertex's outgoing radiance traced against the map itself, no SH. Releases the GIL.\n"
      "\n"
      "Arguments (prt reference's option in brackets):\n"
      "  mesh: the Mesh.\n"
      "  map: an EnvMap, a file name or an (H, W, 3) lat-long array of linear radiance.\n"
      "  samples: paths per vertex (4096) [--samples].\n"
      "  mode: 'unshadowed', 'shadowed' or 'interreflected' [--mode]; bounces: of 'interreflected' [--bounces].\n"
      "  albedo: a number or (r, g, b) in [0, 1] (0.8) [--albedo]; vertex_colors: the mesh's colours as albedo.\n"
      "  seed [--seed], threads [--threads], offset (mesh units; 0: 1e-4 x the diagonal) [--offset].\n"
      "  rotate: the map turned by a 3x3 rotation R or (yaw, pitch, roll) degrees (light from d arrives from R d) [--rotate].\n"
      "  progress: as precompute's.\n"
      "\n"
      "Returns (radiance, std_error): float32 (V, 3) each, linear RGB.");

  m.def(
      "read_vertex_csv",
      [](const py::object& path) {
        std::vector<glm::vec3> se;
        const std::vector<glm::vec3> rgb = prt::read_vertex_csv(path_of(path, "path"), &se);
        return py::make_tuple(vec3s(rgb), se.empty() ? py::object(py::none()) : py::object(vec3s(se)));
      },
      py::arg("path"),
      "Reads the vertex CSV at `path` (prt relight -o x.csv, prt reference): (rgb, std_error or None), float32 (V, 3).");

  m.def(
      "write_vertex_csv",
      [](const py::object& path, const py::object& rgb, const py::object& std_error) {
        const std::vector<glm::vec3> v = to_vec3s(rgb, "rgb");
        std::vector<glm::vec3> se;
        if (!std_error.is_none()) {
          se = to_vec3s(std_error, "std_error");
          if (se.size() != v.size()) throw Error("std_error: expected as many rows as rgb");
        }
        prt::write_vertex_csv(path_of(path, "path"), v, std_error.is_none() ? nullptr : &se);
      },
      py::arg("path"), py::arg("rgb"), py::arg("std_error") = py::none(),
      "Writes a vertex CSV that prt compare reads.\n"
      "\n"
      "Arguments:\n"
      "  path: the file; rgb: float (V, 3) per vertex; std_error: (V, 3) standard errors, or None.");

  // ---- scenes and lightmaps (docs/LIGHTMAPS.md) ----
  py::class_<prt::Scene>(m, "Scene", "A scene (prt/scene.h): objects with materials and UV sets, flattened")
      .def_property_readonly("positions", [](const prt::Scene& s) { return vec3s(s.mesh.positions); },
                             "float32 (V, 3), world space")
      .def_property_readonly("normals", [](const prt::Scene& s) { return vec3s(s.mesh.normals); }, "float32 (V, 3)")
      .def_property_readonly("triangles",
                             [](const prt::Scene& s) {
                               return copy(reinterpret_cast<const std::uint32_t*>(s.mesh.triangles.data()),
                                           {py::ssize_t(s.mesh.triangles.size()), 3});
                             },
                             "uint32 (T, 3)")
      .def_property_readonly("uv_sets",
                             [](const prt::Scene& s) {
                               py::list l;
                               for (const auto& set : s.uv_sets)
                                 l.append(copy(reinterpret_cast<const float*>(set.data()), {py::ssize_t(set.size()), 2}));
                               return l;
                             },
                             "list of float32 (V, 2): TEXCOORD_0, TEXCOORD_1, ... (glTF: origin top-left, v down)")
      .def_property_readonly("objects",
                             [](const prt::Scene& s) {
                               py::list l;
                               for (const auto& o : s.objects)
                                 l.append(py::dict(py::arg("name") = o.name, py::arg("first_triangle") = o.first_triangle,
                                                   py::arg("triangle_count") = o.triangle_count,
                                                   py::arg("material") = o.material, py::arg("uv_sets") = o.uv_sets));
                               return l;
                             })
      .def_property_readonly("hash", &prt::Scene::hash, "Scene hash (a lightmap's scene_hash)")
      .def(
          "lightmap_uv_set",
          [](const prt::Scene& s, int requested) { return s.lightmap_uv_set(uv_set_arg(requested, "requested")); },
          py::arg("requested") = -1,
          "The UV set a lightmap is laid out in: `requested` (0 to 7, TEXCOORD_N; every object must have it) or, "
          "with -1, TEXCOORD_1 when every object has two sets, else TEXCOORD_0 (prt precompute --uv). Raises "
          "prt.Error for any other number, and naming the objects that lack the set.")
      .def("__repr__", [](const prt::Scene& s) { return "<prt.Scene " + prt::describe(s) + ">"; });

  m.def(
      "load_scene",
      [](const py::object& path) {
        const std::string p = path_of(path, "path");
        py::gil_scoped_release release;
        return prt::load_scene(p);
      },
      py::arg("path"), "Reads the glTF 2.0 (.gltf, .glb) or OBJ scene at `path` as prt precompute --lightmap does: its objects, materials and UV sets, flattened into world space. Returns a Scene.");

  py::class_<prt::LightmapTransfer>(m, "Lightmap", "An SH lightmap (prt/lightmap.h): transfer per covered texel")
      .def_property_readonly("width", [](const prt::LightmapTransfer& l) { return l.layout.width; })
      .def_property_readonly("height", [](const prt::LightmapTransfer& l) { return l.layout.height; })
      .def_property_readonly("uv_set", [](const prt::LightmapTransfer& l) { return l.layout.uv_set; })
      .def_property_readonly("scene_hash", [](const prt::LightmapTransfer& l) { return l.layout.scene_hash; })
      .def_property_readonly("bands", [](const prt::LightmapTransfer& l) { return l.transfer.bands; })
      .def_property_readonly("channels", [](const prt::LightmapTransfer& l) { return l.transfer.channels; })
      .def_property_readonly("mode", [](const prt::LightmapTransfer& l) {
        return std::string(prt::transfer_mode_name(l.transfer.mode));
      })
      .def_property_readonly("texels",
                             [](const prt::LightmapTransfer& l) {
                               return copy(l.layout.texels.data(), {py::ssize_t(l.layout.texels.size())});
                             },
                             "uint32 (N,): covered texels, y * width + x (rows from the top)")
      .def_property_readonly("analytic",
                             [](const prt::LightmapTransfer& l) {
                               py::array_t<bool> a(py::ssize_t(l.transfer.vertices));
                               for (std::size_t i = 0; i < l.transfer.vertices; ++i)
                                 a.mutable_at(i) = l.transfer.is_analytic(i);
                               return a;
                             },
                             "bool (N,): texels that store no row (nothing occludes them)")
      .def_property_readonly("interpolated_texels",
                             [](const prt::LightmapTransfer& l) { return l.transfer.interpolated_vertices(); },
                             "How many texels were interpolated from traced neighbours (adaptive sample points, prt "
                             "precompute --lightmap WxH --adaptive); 0 when every texel was traced")
      .def_property_readonly("interpolated",
                             [](py::object self) -> py::object {
                               const auto& l = self.cast<const prt::LightmapTransfer&>();
                               const std::vector<std::uint8_t>& mask = l.transfer.interpolated;
                               if (mask.empty()) return py::none();
                               return view(mask.data(), {py::ssize_t(mask.size())}, self);
                             },
                             "uint8 (N,), read-only: 1 where the texel's transfer was interpolated from traced "
                             "neighbours (precompute_lightmap(adaptive=...), prt precompute --adaptive), 0 where it "
                             "was traced; None when every texel was traced (the file has no interpolated-texel mask)")
      .def(
          "rows",
          [](const prt::LightmapTransfer& l, const prt::Scene& scene) {
            const prt::LightmapTexels tx = prt::lightmap_texels(scene, l.layout.width, l.layout.height, l.layout.uv_set,
                                                                l.transfer.vertex_colors ? nullptr : &l.transfer.albedo);
            prt::check_matches(l, tx, "lightmap");
            const std::vector<float> d = prt::dense_transfer(l.transfer, prt::texel_points(tx));
            return copy(d.data(), {py::ssize_t(l.transfer.vertices), l.transfer.channels,
                                   py::ssize_t(l.transfer.bands) * l.transfer.bands});
          },
          py::arg("scene"),
          "float32 (N, channels, bands^2): every covered texel's transfer, analytic ones evaluated from `scene`")
      .def(
          "relight",
          [](const prt::LightmapTransfer& l, const prt::Scene& scene, const py::object& lighting) {
            const std::vector<glm::dvec3> light = to_coeffs(lighting, "lighting");
            if (light.size() < std::size_t(l.transfer.bands) * l.transfer.bands)
              throw Error("lighting: fewer coefficients than the lightmap's bands^2");
            std::vector<glm::vec4> img;
            {
              py::gil_scoped_release release;
              const prt::LightmapTexels tx =
                  prt::lightmap_texels(scene, l.layout.width, l.layout.height, l.layout.uv_set,
                                       l.transfer.vertex_colors ? nullptr : &l.transfer.albedo);
              prt::check_matches(l, tx, "lightmap");
              img = prt::lightmap_image(l.layout, prt::relight_lightmap(l, tx, light));
            }
            return copy(reinterpret_cast<const float*>(img.data()), {l.layout.height, l.layout.width, 4});
          },
          py::arg("scene"), py::arg("lighting"),
          "The lightmap relit under `lighting` (coefficients (n*n, 3), project()) on `scene` (the Scene it was computed for): "
          "float32 (H, W, 4), prt relight's EXR (RGB linear radiance, A = 1 at covered texels, gutters filled)")
      .def("write", [](const prt::LightmapTransfer& l, const py::object& path) {
        prt::write_lightmap_transfer(path_of(path, "path"), l);
      }, py::arg("path"), "Writes the lightmap file to `path` (docs/FORMAT.md), atomically (a temporary file, then renamed).")
      .def("__repr__", [](const prt::LightmapTransfer& l) {
        return "<prt.Lightmap " + std::to_string(l.layout.width) + "x" + std::to_string(l.layout.height) + ", " +
               std::to_string(l.layout.texels.size()) + " covered texels, " + std::to_string(l.transfer.bands) +
               " bands>";
      });

  m.def("read_lightmap", [](const py::object& path) { return prt::read_lightmap_transfer(path_of(path, "path")); },
        py::arg("path"), "Reads the lightmap file at `path` (prt precompute SCENE --lightmap WxH). Returns a Lightmap.");

  m.def(
      "precompute_lightmap",
      [](const prt::Scene& scene, int width, int height, int uv_set, const std::string& mode, int bands, int samples,
         int bounces, std::uint64_t seed, const py::object& adaptive, double verify_adaptive, bool adaptive_any) {
        prt::TransferOptions o;
        o.mode = prt::parse_transfer_mode(mode);
        o.bands = bands;
        o.samples = samples;
        o.bounces = bounces;
        o.seed = seed;
        const std::optional<prt::AdaptiveOptions> adapt = adaptive_arg(adaptive, verify_adaptive, adaptive_any, samples);
        uv_set_arg(uv_set, "uv_set");
        py::gil_scoped_release release;
        const int set = scene.lightmap_uv_set(uv_set);
        // As the command: an atlas the machine's memory cannot hold is refused
        // from its UV area, before its texels are rasterised.
        prt::TransferOptions planned = o;
        planned.memory_limit = prt::default_memory_limit();
        prt::check_lightmap_memory(scene, width, height, set, planned, adapt.has_value());
        prt::LightmapTexels tx = prt::lightmap_texels(scene, width, height, set);
        prt::move_texels_out_of_geometry(scene.mesh, tx);
        return adapt ? prt::compute_adaptive_lightmap_transfer(scene, tx, o, *adapt)
                     : prt::compute_lightmap_transfer(scene, tx, o);
      },
      py::arg("scene"), py::arg("width"), py::arg("height"), py::kw_only(), py::arg("uv_set") = -1,
      py::arg("mode") = "shadowed", py::arg("bands") = 5, py::arg("samples") = 1024, py::arg("bounces") = 1,
      py::arg("seed") = 1, py::arg("adaptive") = py::none(), py::arg("verify_adaptive") = 0.0,
      py::arg("adaptive_any") = false,
      "The SH lightmap prt precompute SCENE --lightmap WxH computes (the same bits). Releases the GIL.\n"
      "\n"
      "Arguments (prt precompute's option in brackets):\n"
      "  scene: a Scene (load_scene).\n"
      "  width, height: the atlas in texels, 1 to 16384 each [--lightmap WxH].\n"
      "  uv_set: the scene's UV set the atlas is laid out in, 0 to 7 (TEXCOORD_N), or -1: TEXCOORD_1 where every object has it, else TEXCOORD_0 [--uv].\n"
      "  bands (1 to 16) [--bands], samples (rays per texel) [--samples], mode [--mode], bounces [--bounces], seed [--seed]: as precompute's.\n"
      "  adaptive [--adaptive [TOL]], verify_adaptive [--verify-adaptive], adaptive_any [--adaptive-any]: as precompute's, among the texels: None traces every texel; 0 (the default TOL) or a TOL in (0, 1) traces a subset and interpolates the rest from neighbouring texels of the same chart. The Lightmap's .interpolated marks the interpolated texels.\n"
      "\n"
      "Returns a Lightmap.");

  m.def(
      "lightmap_from_rows",
      [](const prt::Scene& scene, int width, int height, const py::object& rows, int uv_set, const std::string& mode) {
        FArray a = real_array<float>(rows, "rows");
        const int set = scene.lightmap_uv_set(uv_set_arg(uv_set, "uv_set"));
        const prt::LightmapTexels tx = prt::lightmap_texels(scene, width, height, set);
        const std::size_t n = tx.layout.texels.size();
        if (a.ndim() != 3 || std::size_t(a.shape(0)) != n || (a.shape(1) != 1 && a.shape(1) != 3))
          throw Error("rows: expected float32 (" + std::to_string(n) + ", 1 or 3, bands^2) for this atlas's covered texels");
        const int bands = int(std::lround(std::sqrt(double(a.shape(2)))));
        if (bands < 1 || bands * bands != a.shape(2)) throw Error("rows: the last axis must be bands^2");
        prt::LightmapTransfer l;
        l.layout = tx.layout;
        prt::Transfer& t = l.transfer;
        t.bands = bands;
        t.channels = int(a.shape(1));
        t.mode = prt::parse_transfer_mode(mode);
        t.vertices = n;
        t.vertex_colors = true;
        t.mesh_hash = tx.layout.scene_hash;
        t.shading_hash = prt::shading_hash(prt::texel_points(tx), true);
        t.coeffs.assign(a.data(), a.data() + a.size());
        if (auto p = prt::lightmap_problem(l); !p.empty()) throw Error("rows: " + p);
        return l;
      },
      py::arg("scene"), py::arg("width"), py::arg("height"), py::arg("rows"), py::kw_only(), py::arg("uv_set") = -1,
      py::arg("mode") = "shadowed",
      "A lightmap from arrays, for a Scene: every texel of the atlas stored (none analytic); .write() makes a file prt relight reads.\n"
      "\n"
      "Arguments:\n"
      "  scene: the Scene; width, height: the atlas in texels, 1 to 16384 each; uv_set: its UV set, 0 to 7 (-1: as precompute_lightmap).\n"
      "  rows: float32 (N, channels, bands^2), one per covered texel, in texel order.\n"
      "  mode: the transfer mode recorded ('shadowed', 'interreflected', ...).\n"
      "\n"
      "Returns a Lightmap.");

  // ---- probe volumes (prt/probes.h, docs/PROBES.md) -------------------------------
  py::class_<prt::ProbeTransfer>(m, "ProbeVolume", "A relightable probe volume (prt precompute SCENE --probes)")
      .def_property_readonly("dims", [](const prt::ProbeTransfer& t) { return py::make_tuple(t.grid.dims[0], t.grid.dims[1], t.grid.dims[2]); })
      .def_property_readonly("min", [](const prt::ProbeTransfer& t) { return py::make_tuple(t.grid.min.x, t.grid.min.y, t.grid.min.z); })
      .def_property_readonly("max", [](const prt::ProbeTransfer& t) { return py::make_tuple(t.grid.max.x, t.grid.max.y, t.grid.max.z); })
      .def_property_readonly("bands", [](const prt::ProbeTransfer& t) { return t.bands; })
      .def_property_readonly("mode", [](const prt::ProbeTransfer& t) { return std::string(prt::transfer_mode_name(t.mode)); })
      .def_property_readonly("scene_hash", [](const prt::ProbeTransfer& t) { return t.scene_hash; })
      .def_property_readonly("states",
                             [](const prt::ProbeTransfer& t) {
                               py::array_t<std::uint8_t> a(py::ssize_t(t.state.size()));
                               for (std::size_t i = 0; i < t.state.size(); ++i) a.mutable_at(i) = std::uint8_t(t.state[i]);
                               return a;
                             },
                             "uint8 (P,): 0 sky (stores nothing), 1 stored, 2 invalid (inside geometry); probe i + NX (j + NY k)")
      .def_property_readonly("positions",
                             [](const prt::ProbeTransfer& t) {
                               return copy(reinterpret_cast<const float*>(t.positions.data()), {py::ssize_t(t.positions.size()), 3});
                             },
                             "float32 (P, 3): where each probe is (grid points moved off surfaces)")
      .def_property_readonly("nbytes", &prt::ProbeTransfer::bytes)
      .def(
          "relight",
          [](const prt::ProbeTransfer& t, const py::object& map, const py::object& rotate) {
            prt::EnvMap loaded;
            const prt::EnvMap* e = &map_argument(map, loaded);
            const glm::dmat3 R = rotate.is_none() ? glm::dmat3(1.0) : to_rotation(rotate, "rotate");
            std::vector<glm::vec3> lit;
            {
              py::gil_scoped_release release;
              prt::ProbeRelighter r(t, *e);
              r.set_rotation(R);
              r.relight(lit);
            }
            const py::ssize_t nc = py::ssize_t(t.bands) * t.bands;
            return copy(reinterpret_cast<const float*>(lit.data()), {py::ssize_t(t.probes()), nc, 3});
          },
          py::arg("map"), py::kw_only(), py::arg("rotate") = py::none(),
          "float32 (P, bands^2, 3): every probe's incident light's SH under the map (a file, an EnvMap or an array), "
          "rotated as prt relight --rotate")
      .def(
          "at",
          [](const prt::ProbeTransfer& t, const prt::Scene& scene, const py::object& points, const py::object& normals,
             const py::object& sh) {
            DArray p = real_array<double>(points, "points"), n = real_array<double>(normals, "normals");
            FArray l = real_array<float>(sh, "sh");
            const py::ssize_t nc = py::ssize_t(t.bands) * t.bands;
            if (p.ndim() != 2 || p.shape(1) != 3 || n.ndim() != 2 || n.shape(0) != p.shape(0) || n.shape(1) != 3)
              throw Error("points and normals: float (N, 3) each, as many normals as points; got " + shape_text(p) +
                          " and " + shape_text(n));
            if (l.ndim() != 3 || l.shape(0) != py::ssize_t(t.probes()) || l.shape(1) != nc || l.shape(2) != 3)
              throw Error("sh: float32 (P, bands^2, 3), what relight() returns");
            if (scene.hash() != t.scene_hash) throw Error("scene: not the scene the probe volume was computed for");
            const std::size_t N = std::size_t(p.shape(0));
            // Every normal non-zero, and used as a unit normal: prt relight --at's rule for its points' normals.
            std::vector<glm::dvec3> unit(N);
            for (std::size_t i = 0; i < N; ++i) {
              const glm::dvec3 nn(n.at(i, 0), n.at(i, 1), n.at(i, 2));
              const double big = std::max({std::abs(nn.x), std::abs(nn.y), std::abs(nn.z)});  // finite (real_array)
              if (!(big > 0))
                throw Error("normals: row " + std::to_string(i) + " is (" + number_text(nn.x) + ", " +
                            number_text(nn.y) + ", " + number_text(nn.z) +
                            "); each normal must be non-zero (it is normalised)");
              const double len = std::sqrt(nn.x * nn.x + nn.y * nn.y + nn.z * nn.z);  // as read_points_csv
              unit[i] = len > 0 && std::isfinite(len) ? nn / len : glm::normalize(nn / big);
            }
            std::vector<float> out(N * 3);
            {
              py::gil_scoped_release release;
              const std::vector<std::uint32_t> slots = t.stored_slots();
              const prt::ProbeOcclusion occlusion(scene.mesh, t.grid);
              const prt::ProbeVisibility visible = [&](const glm::dvec3& a, const glm::dvec3& b) { return occlusion(a, b); };
              const float* L = l.data();
              for (std::size_t i = 0; i < N; ++i) {
                const glm::dvec3 q(p.at(i, 0), p.at(i, 1), p.at(i, 2)), nn = unit[i];
                const prt::ProbeWeights w = prt::probe_weights(t, slots, q, nn, visible);
                std::vector<glm::vec3> mix(std::size_t(nc), glm::vec3(0.0f));
                for (int c = 0; c < w.count; ++c)
                  for (py::ssize_t k = 0; k < nc; ++k) {
                    const float* src = L + (std::size_t(w.probe[std::size_t(c)]) * std::size_t(nc) + std::size_t(k)) * 3;
                    mix[std::size_t(k)] += w.weight[std::size_t(c)] * glm::vec3(src[0], src[1], src[2]);
                  }
                const glm::dvec3 e = prt::lambert_from_sh(mix, t.bands, nn);
                for (int c = 0; c < 3; ++c) out[i * 3 + std::size_t(c)] = float(e[c]);
              }
            }
            return copy(out.data(), {py::ssize_t(N), 3});
          },
          py::arg("scene"), py::arg("points"), py::arg("normals"), py::arg("sh"),
          "float32 (N, 3): E(p, n)/pi at `points` (N, 3) with `normals` (N, 3; each non-zero, normalised) in `scene` "
          "(the Scene the volume was computed for) from the relit probes `sh` (relight()'s), as prt relight --at "
          "(traced visibility). Points and normals must be finite.")
      .def(
          "matrices",
          [](const prt::ProbeTransfer& t, int in_bands) {
            if (in_bands < 1 || in_bands > prt::kMaxProbeMatrixBands)
              throw Error("in_bands: 1 to " + std::to_string(prt::kMaxProbeMatrixBands) + ", got " +
                          std::to_string(in_bands));
            int channels = 1;
            const std::vector<float> mm = prt::probe_sh_matrices(t, in_bands, channels);
            return copy(mm.data(), {py::ssize_t(t.probes()), channels, py::ssize_t(t.bands) * t.bands,
                                    py::ssize_t(in_bands) * in_bands});
          },
          py::arg("in_bands") = 3,
          "float32 (P, channels, bands^2, in_bands^2): the SH transfer matrices prt export --matrices writes (in_bands "
          "1 to 16, --matrix-bands)")
      .def("write", [](const prt::ProbeTransfer& t, const py::object& path) { prt::write_probe_transfer(path_of(path, "path"), t); },
           py::arg("path"), "Writes the probe file to `path` (docs/FORMAT.md \"Probe volume\"), atomically.")
      .def("__repr__", [](const prt::ProbeTransfer& t) {
        return "<prt.ProbeVolume " + std::to_string(t.grid.dims[0]) + "x" + std::to_string(t.grid.dims[1]) + "x" +
               std::to_string(t.grid.dims[2]) + ", " + std::to_string(t.stored()) + " stored, " +
               std::string(prt::transfer_mode_name(t.mode)) + ">";
      });

  m.def("read_probes", [](const py::object& path) { return prt::read_probe_transfer(path_of(path, "path")); }, py::arg("path"),
        "Reads the probe volume at `path` (prt precompute SCENE --probes NXxNYxNZ). Returns a ProbeVolume.");

  m.def(
      "export_probes",
      [](const py::object& probes, const prt::Scene& scene, const py::object& bake, const py::object& path,
         const py::object& rotate, const py::object& matrices, int matrix_bands) {
        const std::string out = path_of(path, "path");
        // A ProbeVolume, or its file (named in the JSON as prt export names it).
        std::optional<prt::ProbeTransfer> read;
        std::string probes_file = "<computed>", probes_path;
        if (is_path(probes)) {
          probes_path = path_of(probes, "probes");
          read = prt::read_probe_transfer(probes_path);
          probes_file = std::filesystem::path(probes_path).filename().string();
        } else if (!py::isinstance<prt::ProbeTransfer>(probes)) {
          throw Error("probes: expected a ProbeVolume (read_probes, precompute_probes) or its file");
        }
        const prt::ProbeTransfer& t = read ? *read : probes.cast<const prt::ProbeTransfer&>();
        if (!is_path(bake)) throw Error("bake: expected a map file (str or os.PathLike), as prt export --bake");
        const std::string map = path_of(bake, "bake");
        if (scene.hash() != t.scene_hash)
          throw Error("probes: computed for another scene than `scene` (scene hashes differ)");
        std::string ext = std::filesystem::path(out).extension().string();
        for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
        if (ext != ".json") throw Error("path: " + out + ": a probe volume exports as .json");
        std::array<double, 3> euler = {0, 0, 0};
        if (!rotate.is_none()) {
          const DArray r = real_array<double>(rotate, "rotate");
          if (r.ndim() != 1 || r.shape(0) != 3)
            throw Error("rotate: (yaw, pitch, roll) in degrees, as prt export --rotate (recorded in the file)");
          for (int k = 0; k < 3; ++k) euler[std::size_t(k)] = r.data()[k];
        }
        if (matrix_bands < 1 || matrix_bands > prt::kMaxProbeMatrixBands)  // prt export --matrix-bands's range
          throw Error("matrix_bands: 1 to " + std::to_string(prt::kMaxProbeMatrixBands) + ", got " +
                      std::to_string(matrix_bands));
        if (matrices.is_none() && matrix_bands != 3) throw Error("matrix_bands: applies with matrices= (a file)");
        const std::string matrices_path = matrices.is_none() ? std::string() : path_of(matrices, "matrices");
        // No output over an input (prt export's rule), nor the matrices over the JSON.
        const std::vector<NamedInput> inputs = {{"probes", probes_path}, {"bake", map}, {"scene", scene.mesh.source}};
        check_not_input("path", out, inputs);
        if (!matrices_path.empty()) {
          check_not_input("matrices", matrices_path, inputs);
          if (prt::same_file(matrices_path, out))
            throw Error("matrices: " + matrices_path + ": is also path" + (matrices_path == out ? "" : " (" + out + ")") +
                        ", the JSON; the two outputs need two files (choose another name for one)");
        }
        py::gil_scoped_release release;
        prt::EnvMap env = prt::load_envmap(map);
        prt::require_finite(env);
        prt::ProbeExportNames names;
        names.scene = std::filesystem::path(scene.mesh.source).filename().string();
        names.probes_file = probes_file;
        names.map = std::filesystem::path(map).filename().string();
        names.generator = "prt " PRT_VERSION " (prt export)";
        const std::string text = prt::probe_engine_json(t, env, euler, names);
        int channels = 1;
        const std::vector<float> mats =
            matrices_path.empty() ? std::vector<float>() : prt::probe_sh_matrices(t, matrix_bands, channels);
        // Both files or neither (prt export's outputs are staged alike).
        prt::StagedWrites staged;
        {
          prt::StagedWrites::Scope scope(staged);
          prt::write_text_file(out, text);
          if (!matrices_path.empty()) prt::write_probe_matrices(matrices_path, t, mats, matrix_bands, channels);
        }
        staged.commit();
      },
      py::arg("probes"), py::arg("scene"), py::arg("bake"), py::arg("path"), py::kw_only(),
      py::arg("rotate") = py::none(), py::arg("matrices") = py::none(), py::arg("matrix_bands") = 3,
      "Writes to `path` what prt export SCENE --probes PROBES --bake MAP -o PATH writes for the volume of `scene` (the same bytes): every probe relit "
      "under the map (bake: a map file, turned by rotate, yaw, pitch, roll degrees) as three.js LightProbe and "
      "Unity SphericalHarmonicsL2 coefficients, with positions in both engines' axes (docs/PROBES.md \"Export\"). "
      "PATH ends in .json. probes: a ProbeVolume or its file (the file's name is recorded, as the command records "
      "it). matrices: also write each probe's SH transfer matrix (--matrices FILE.bin), taking matrix_bands bands "
      "of lighting, 1 to 16 (--matrix-bands). Neither output may be an input (the probes file, the map, the "
      "scene's file) or the other output; both are written, or neither.");

  m.def(
      "precompute_probes",
      [](const prt::Scene& scene, const py::object& dims, const std::string& mode, int bands, int bounce_bands,
         int bounces, std::uint64_t seed) {
        const std::array<int, 3> dd = probe_dims_arg(dims);
        prt::ProbeOptions o;
        o.mode = prt::parse_transfer_mode(mode);
        o.bands = bands;
        o.bounce_bands = bounce_bands;
        o.bounces = bounces;
        o.seed = seed;
        if (scene.materials.empty()) {  // a bare mesh: prt precompute's --albedo default
          o.override_albedo = true;
          o.albedo = glm::vec3(0.8f);
        }
        py::gil_scoped_release release;
        return prt::compute_probe_transfer(scene, prt::probe_grid(scene.mesh, dd), o);
      },
      py::arg("scene"), py::arg("dims"), py::kw_only(), py::arg("mode") = "shadowed", py::arg("bands") = 3,
      py::arg("bounce_bands") = 6, py::arg("bounces") = 1, py::arg("seed") = 1,
      "The relightable probe volume prt precompute SCENE --probes NXxNYxNZ computes (the same bits). Releases the GIL.\n"
      "\n"
      "Arguments (prt precompute's option in brackets):\n"
      "  scene: a Scene (load_scene).\n"
      "  dims: (NX, NY, NZ) probes, three whole numbers, each 2 to 1024 and at most 16777216 in all, spanning the scene's bounding box, corners included [--probes].\n"
      "  mode: 'shadowed' or 'interreflected' [--mode]; bands: of each probe's SH, 1 to 8 (3) [--bands].\n"
      "  bounce_bands: the environment bands the bounce light takes, 1 to 16 (6) [--bounce-bands]; bounces: 1 to 8, interreflected [--bounces]; seed [--seed].\n"
      "\n"
      "Returns a ProbeVolume.");
}
