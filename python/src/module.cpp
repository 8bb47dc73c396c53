// python/src/module.cpp - prt's Python module (pybind11): maps, meshes,
// transfer files and the computations of the prt command as numpy arrays.
// The top layer, like tools/prt: it only calls the libraries (docs/PYTHON.md).
//
// The definitions live in one file per area (bind_<area>.cpp); what they
// share, and the order they register in, is module.h's.
#include "module.h"

#include <prt/paths.h>
#include <prt/sh.h>

PYBIND11_MODULE(_prt, m) {
  using namespace prt::python;
  m.doc() = "prt: Precomputed Radiance Transfer (docs/PYTHON.md)";
  // The renderer's thread stops before the interpreter does (bind_render.cpp's GlWorker).
  py::module_::import("atexit").attr("register")(py::cpp_function([] { stop_renderer(); }));
  m.attr("__version__") = PRT_VERSION;
  m.attr("MAX_BANDS") = prt::sh::kMaxBands;
  // prt::Error (a user's mistake, naming the file or option) -> prt.Error.
  py::register_exception<prt::Error>(m, "Error", PyExc_RuntimeError);

  m.def("data_dir", [] { return prt::data_dir().string(); },
        "The directory of prt's bundled data (envmaps/): $PRT_DATA_DIR, or the one installed with prt.");

  // The areas, in this order (module.h): a class before the functions whose
  // signatures name it; relight() of a Transfer after precompute, then of a
  // WaveletTransfer (bind_wavelet) and of a ZhTransfer (bind_ldprt); export
  // last (it takes a Transfer or a Lightmap).
  bind_maps(m);
  bind_mesh(m);
  bind_lights(m);
  bind_transfer(m);
  bind_precompute(m);
  bind_transfer_relight(m);
  bind_render(m);
  bind_info(m);
  bind_compress(m);
  bind_wavelet(m);
  bind_ldprt(m);
  bind_reference(m);
  bind_lightmap(m);
  bind_probes(m);
  bind_export(m);  // after the Lightmap class its overloads name
}
