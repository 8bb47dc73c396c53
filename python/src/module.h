// python/src/module.h - what the binding files of prt's Python module share
// (private to python/src; defined in helpers.cpp): arrays, the checks of
// arguments, the GIL and progress helpers, the transfers as Python holds
// them, and each file's bind_<area>, which module.cpp calls in the order the
// definitions register (docs/PYTHON.md).
//
// Arrays prt owns (a map's pixels, a mesh's vertices, a transfer's rows) are
// read-only views that keep their object alive; everything computed is a new
// array. Long computations (precompute, reference) release the GIL; their
// progress callback takes it back, and Ctrl-C or an exception raised by the
// callback stops them (the library's Progress returns false: prt/progress.h).
#pragma once

#include <prt/compressed_transfer.h>
#include <prt/direct_light.h>
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/lights.h>
#include <prt/point_tracer.h>
#include <prt/precompute.h>
#include <prt/progress.h>
#include <prt/subsurface.h>
#include <prt/transfer_file.h>
#include <prt/transfer.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh_transfer.h>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

namespace py = pybind11;

namespace prt::python {

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

py::array_t<float> vec3s(const std::vector<glm::vec3>& v);

using DArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using FArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using UArray = py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast>;

std::string shape_text(const py::array& a);

// A read-only (N, 3) view of glm vectors (three floats each, packed).
template <typename V>
py::array view3(const std::vector<V>& v, py::handle owner) {
  using T = typename V::value_type;
  return view(v.empty() ? nullptr : reinterpret_cast<const T*>(v.data()), {py::ssize_t(v.size()), 3}, owner);
}

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

py::array arg_array(const py::handle& obj, const std::string& what);

// The [i, j, ...] position of flat element k of an array of `shape`.
std::string index_text(std::size_t k, const py::array& a);

std::string number_text(double x);

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
UArray index_array(const py::handle& obj, const std::string& what);

// A whole-number argument: a Python or numpy integer (not a bool, not a
// float, even a whole one: a count is written as one), within int's range.
int int_arg(const py::handle& obj, const std::string& what);

// Lighting coefficients (n*n, 3), float64, every one finite (a NaN would
// reach every vertex).
std::vector<glm::dvec3> to_coeffs(const py::handle& obj, const char* what);

// A number, or three (r, g, b); the library checks the range [0, 1].
glm::vec3 to_albedo(const py::handle& obj);

// A rotation: a 3x3 matrix, or (yaw, pitch, roll) in degrees as --rotate.
// A rotation matrix must be one: orthonormal to this (a float32 matrix's
// rounding, 1e-7 per entry, with room) and of determinant +1 (no mirror).
constexpr double kRotationTol = 1e-5;

glm::dmat3 to_rotation(const py::handle& obj, const char* what);

// An (N, 3) array of finite values (exactly N rows when `rows` is given).
std::vector<glm::vec3> to_vec3s(const py::handle& obj, const char* what, std::optional<std::size_t> rows = {},
                                const char* rows_of = nullptr);

// ---- progress, Ctrl-C ----------------------------------------------------------

// While one lives on Python's main thread, SIGINT sets a flag instead of
// running Python's handler (which cannot run while the GIL is released);
// the destructor puts Python's handler back. Elsewhere, or when SIGINT is not
// Python's default handler, it leaves SIGINT alone.
class InterruptScope {
 public:
  InterruptScope();
  ~InterruptScope();
  bool interrupted() const;
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
  explicit PyProgress(py::object callback);
  ~PyProgress() = default;
  bool interrupted() const { return interrupts_.interrupted(); }

  prt::Progress callback() {
    return [this](std::size_t done, std::size_t total, const char* phase) { return update(done, total, phase); };
  }

  // After the computation (GIL held): raises what stopped it, if Python did.
  // `e` is the library's exception, rethrown when Python did not stop it.
  [[noreturn]] void rethrow(const std::exception_ptr& e);

 private:
  bool update(std::size_t done, std::size_t total, const char* phase);

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

// ---- options shared by several calls -------------------------------------------

// adaptive=, verify_adaptive=, adaptive_any= of precompute and
// precompute_lightmap: prt precompute's --adaptive [TOL], --verify-adaptive
// F and --adaptive-any, the same rules (tools/prt/cmd_precompute.cpp,
// parse_adaptive). None: every point traced; 0 is --adaptive without a
// value (default_adaptive_tolerance(samples)); a TOL in (0, 1), refused
// above max_adaptive_tolerance(samples) unless adaptive_any. Returns the
// options, or nothing for adaptive=None.
std::optional<prt::AdaptiveOptions> adaptive_arg(const py::object& adaptive, double verify, bool any, int samples);
// device= (precompute, precompute_lightmap): 'cpu' or 'gpu', refused where
// the GPU does not trace: a kind the kind table says it does not make
// (prt/transfer_file.h, Consumer::GpuPrecompute: its sentence), a
// subsurface material; device_tracer: the GL tracer of `mesh` for 'gpu'
// (the flat BVH built, a context made: prt.Error where there is none), else
// null.
void check_device_arg(const std::string& device, prt::TransferKind kind, const std::string& material);
std::unique_ptr<prt::PointTracer> device_tracer(const std::string& device, const prt::Mesh& mesh);
// (NX, NY, NZ) by prt::probe_dims_problem's rule, errors naming `what`.
std::array<int, 3> probe_dims_arg(const py::object& dims, const std::string& what = "dims");
// light_bounce= and its shaping arguments (prt precompute --light-bounce,
// --bounce-patch, --bounce-ratio, --bounce-clusters, --probes) into `o`;
// throws prt::Error for a shaping argument without light_bounce.
void light_bounce_args(prt::TransferOptions& o, bool light_bounce, double patch, double ratio, int clusters,
                       const py::object& probes);

// material='subsurface' of precompute and precompute_lightmap (defined in
// bind_precompute.cpp; docs/SUBSURFACE.md): prt precompute --material
// subsurface's options by the CLI's names, and its refusals.
//
// length_scale='s default, prt precompute --length-scale's
// (tools/prt/subsurface_options.h): D3DX's samples' fLengthScale, 25 mm a
// mesh unit.
constexpr double kDefaultLengthScale = 25.0;
// sss=, sigma_a=, sigma_s=, eta= or length_scale= given with another
// material than 'subsurface': refused by the argument's name.
void check_subsurface_given(const std::string& material, const py::object& sss, const py::object& sigma_a,
                            const py::object& sigma_s, const py::object& eta, double length_scale);
// The translucent material of material='subsurface', as prt precompute's
// --sss, --sigma-a, --sigma-s, --eta and --length-scale give it
// (tools/prt/subsurface_options.cpp): the preset, its values overridden (its
// name then marked "(modified)"), or both coefficients (eta 1.3 unless given).
prt::SubsurfaceRecord subsurface_arg(const py::object& sss, const py::object& sigma_a, const py::object& sigma_s,
                                     const py::object& eta, double length_scale);
// What prt precompute --material subsurface refuses, by the argument's name
// with the CLI's reason (tools/prt/cmd_precompute.cpp, check_subsurface).
void check_subsurface_args(const std::string& basis, const std::string& mode, const py::object& albedo,
                           bool vertex_colors, bool adaptive, bool light_bounce);

// threads=: prt's --threads, 0 (every core) to prt::kMaxThreads.
int threads_arg(int threads);

// An exposure in stops given by the caller (not 'auto'): finite (the
// wrapper) and within the command's --exposure range, +-kMaxExposureStops.
double exposure_arg(const py::object& exposure);

// fov=: vertical degrees in prt's --fov range, or None (the default camera's
// field of view: 40 degrees, 70 inside a room; prt render --fov).
std::optional<double> fov_arg(const py::object& fov);

// terms=: the wavelet terms K, 1 to wavelet::kMaxTerms (--terms).
void check_terms(int terms);

// rho_d of diffuse=: a number or (r, g, b), each an albedo in [0, 1] (--diffuse).
glm::dvec3 diffuse_arg(const py::object& diffuse);

// An output file named `what` of a call must be none of its inputs (a file
// named by the call, a Mesh or Scene read from a file): prt's commands' rule
// (the same file through a link too: prt::same_file).
struct NamedInput {
  std::string name, path;
};
void check_not_input(const std::string& what, const std::string& out, const std::vector<NamedInput>& inputs);

// ---- files and maps ------------------------------------------------------------

bool is_path(const py::handle& h);
// A file name argument (str or os.PathLike) as a string; `what` names it.
std::string path_of(const py::handle& h, const std::string& what);

// A map argument: an EnvMap (returned as is), a file name or an array
// (loaded into `storage`, which is returned).
const prt::EnvMap& map_argument(const py::object& map, prt::EnvMap& storage);

// An array (H, W, 3) (lat-long) or (6, N, N, 3) (cube faces) as a map.
prt::EnvMap map_from_array(const py::handle& obj);

// ---- lights inside the scene (bind_lights.cpp; docs/LIGHTS.md) -----------------
//
// The lights= and sun= arguments of the relighting calls and reference(),
// prt relight's and prt reference's --lights and --sun. lights= is the whole
// list: a Scene's own lights (Scene.lights) are not added unless passed.

// lights=: None (no lights) or a list (any iterable but a str) of prt.Light.
std::vector<prt::Light> lights_arg(const py::object& lights, const char* what = "lights");

// sun=: 'none' (false) or 'auto' (true), as --sun.
bool sun_arg(const std::string& sun);

// sun='auto' (tools/prt/light_options.cpp's take_sun): takes the map's sun out
// of `map` (in place: the sky stays) and returns it as a directional light
// turned by `rotation` (the lighting's); nullopt when the map has no compact
// bright source.
std::optional<prt::Light> take_sun(prt::EnvMap& map, const glm::dmat3& rotation);

// Adds the lights' direct light (prt::DirectLight: albedo/pi x irradiance,
// each light's shadow ray traced against `occluders`) at the points to
// `rgb`, as prt relight's add_lights, and with a transfer's light-bounce
// operator (prt/light_bounce.h; empty: none) their bounce. Nothing without
// lights. Call without the GIL.
void add_direct_light(std::vector<glm::vec3>& rgb, const std::vector<prt::Light>& lights, const prt::Mesh& occluders,
                      std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                      std::span<const glm::vec3> albedo, const std::optional<prt::GlossyLobe>& lobe = std::nullopt,
                      const prt::LightBounce& bounce = {});

// ---- transfers -----------------------------------------------------------------

// An SH transfer as Python sees it: the whole transfer (a compressed file's
// rows reconstructed) and, for a compressed file, the compressed form, which
// relight() uses as prt relight does.
struct PyTransfer {
  prt::Transfer t;
  std::optional<prt::CompressedTransfer> compressed;
  std::string source = "<computed>";
};

// A local deformable transfer (prt/zh_transfer.h, docs/LDPRT.md) and where it
// came from, which names it in messages (as PyTransfer's source).
struct PyZhTransfer {
  prt::ZhTransfer z;
  std::string source = "<computed>";
};

// A wavelet transfer (prt/wavelet_transfer.h, docs/WAVELETS.md) and its source.
struct PyWavelet {
  prt::WaveletTransfer t;
  std::string source = "<computed>";
};

// ---- the areas, in the order module.cpp registers them -------------------------
//
// A class registers before the functions whose signatures name it, and the
// overloads of relight() register in the order pybind11 tries them
// (Transfer, WaveletTransfer, ZhTransfer): the signatures, docstrings and
// type stubs (python/make_stubs.py) follow that order.

void bind_maps(py::module_& m);              // bind_maps.cpp: EnvMap, load_envmap, project, SH
void bind_mesh(py::module_& m);              // bind_mesh.cpp: Mesh, load_mesh, make_mesh
void bind_lights(py::module_& m);            // bind_lights.cpp: Light, read_lights, split_sun, direct_light
void bind_transfer(py::module_& m);          // bind_transfer.cpp: Transfer, read_transfer
void bind_precompute(py::module_& m);        // bind_precompute.cpp: precompute
void bind_transfer_relight(py::module_& m);  // bind_transfer.cpp: relight (Transfer)
void bind_render(py::module_& m);            // bind_render.cpp: render
void bind_export(py::module_& m);            // bind_export.cpp: export_gltf, export_web
void bind_info(py::module_& m);              // bind_info.cpp: info, verify
void bind_compress(py::module_& m);          // bind_compress.cpp: compress, compression_error
void bind_wavelet(py::module_& m);           // bind_wavelet.cpp: WaveletTransfer, read_wavelet, relight
void bind_ldprt(py::module_& m);             // bind_ldprt.cpp: ZhTransfer, fit_zh, deform, pose, relight
void bind_reference(py::module_& m);         // bind_reference.cpp: reference, vertex CSV files
void bind_lightmap(py::module_& m);          // bind_lightmap.cpp: Scene, Lightmap and theirs
void bind_probes(py::module_& m);            // bind_probes.cpp: ProbeVolume and its calls

// Stops render()'s OpenGL thread, if it started (bind_render.cpp); module.cpp
// calls it at interpreter exit.
void stop_renderer();

}  // namespace prt::python
