// python/src/bind_info.cpp - prt's Python module: info (what a prt file
// holds, as prt info --json) and verify (prt verify's checks as records).
#include "module.h"

#include <prt/file_info.h>
#include <prt/sh.h>
#include <prt/verify.h>

namespace prt::python {

// info, verify.
void bind_info(py::module_& m) {
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
}

}  // namespace prt::python
