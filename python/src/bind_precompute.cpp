// python/src/bind_precompute.cpp - prt's Python module: precompute, the
// transfer of a mesh (SH, adaptive sample points, or wavelet).
#include "module.h"

#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/subsurface.h>
#include <prt/subsurface_scatter.h>
#include <prt/wavelet_transfer.h>

#include <glm/vec3.hpp>

namespace prt::python {

namespace {

// sigma_a=, sigma_s=: three numbers r, g, b (1/mm).
glm::dvec3 coefficients_arg(const py::object& o, const char* what) {
  std::vector<double> v;
  try {
    v = py::cast<std::vector<double>>(o);
  } catch (const py::cast_error&) {
    throw Error(std::string(what) + ": expected 3 numbers r, g, b (1/mm)");
  }
  if (v.size() != 3) throw Error(std::string(what) + ": expected 3 numbers r, g, b (1/mm), got " + std::to_string(v.size()));
  return {v[0], v[1], v[2]};
}

}  // namespace

// material='subsurface''s arguments (module.h), precompute_lightmap's too.
void check_subsurface_given(const std::string& material, const py::object& sss, const py::object& sigma_a,
                            const py::object& sigma_s, const py::object& eta, double length_scale) {
  if (material == "subsurface") return;
  for (const auto& [given, name] : {std::pair{!sss.is_none(), "sss"}, std::pair{!sigma_a.is_none(), "sigma_a"},
                                    std::pair{!sigma_s.is_none(), "sigma_s"}, std::pair{!eta.is_none(), "eta"},
                                    std::pair{length_scale != kDefaultLengthScale, "length_scale"}})
    if (given) throw Error(std::string(name) + ": needs material='subsurface'");
}

prt::SubsurfaceRecord subsurface_arg(const py::object& sss, const py::object& sigma_a, const py::object& sigma_s,
                                     const py::object& eta, double length_scale) {
  prt::SubsurfaceRecord r;
  r.length_scale = length_scale;
  if (!(length_scale > 0) || !std::isfinite(length_scale))
    throw Error("length_scale: millimetres per mesh unit, a positive number, got " + number_text(length_scale));
  if (!sss.is_none()) {
    const std::string name = py::cast<std::string>(sss);
    const std::optional<prt::SubsurfaceMaterial> m = prt::subsurface_preset(name);
    if (!m) throw Error("sss: no measured material '" + name + "' (one of " + prt::subsurface_preset_names() + ")");
    r.material = *m;
  } else if (sigma_a.is_none() || sigma_s.is_none()) {
    throw Error("material='subsurface' needs sss=NAME (" + prt::subsurface_preset_names() +
                ") or both sigma_a and sigma_s (r, g, b in 1/mm)");
  }
  if (!sigma_a.is_none()) r.material.sigma_a = coefficients_arg(sigma_a, "sigma_a");
  if (!sigma_s.is_none()) r.material.sigma_s = coefficients_arg(sigma_s, "sigma_s");
  if (!eta.is_none()) r.material.eta = py::cast<double>(eta);
  if (!sss.is_none() && (!sigma_a.is_none() || !sigma_s.is_none() || !eta.is_none())) r.material.name += " (modified)";
  prt::check_subsurface_material(r.material, "material='subsurface'");
  return r;
}

void check_subsurface_args(const std::string& basis, const std::string& mode, const py::object& albedo,
                           bool vertex_colors, bool adaptive, bool light_bounce) {
  const auto no = [](const std::string& what, const std::string& why) {
    throw Error(what + ": does not apply to material='subsurface': " + why);
  };
  if (basis != "sh")
    no("basis", "its exit radiance is view-independent and smooth (the dipole spreads light over millimetres), so SH "
                "transfer vectors hold it; leave basis out");
  if (mode == "unshadowed")
    throw Error("mode: material='subsurface' is shadowed or interreflected: the light entering each vertex is traced "
                "(unshadowed light would pass through the object's other side)");
  if (vertex_colors || to_albedo(albedo) != glm::vec3(0.8f))
    no(vertex_colors ? "vertex_colors" : "albedo",
       "the material's reflectance is its profile (sss, or sigma_a and sigma_s), not an albedo");
  if (adaptive) no("adaptive", "the surface integral sums every vertex's traced light");
  if (light_bounce) no("light_bounce", "the lights' bounce operator is a diffuse surface's");
}

// precompute.
void bind_precompute(py::module_& m) {
  m.def(
      "precompute",
      [](const prt::Mesh& mesh, const py::object& bands_arg, int samples, const std::string& mode, int bounces,
         const py::object& albedo, bool vertex_colors, std::uint64_t seed, int threads, double offset,
         double bounce_tolerance, const std::string& material, const std::string& basis, int cube_res,
         double threshold, const py::object& adaptive, double verify_adaptive, bool adaptive_any, bool light_bounce,
         double bounce_patch, double bounce_ratio, int bounce_clusters, const py::object& bounce_probes,
         const py::object& sss, const py::object& sigma_a, const py::object& sigma_s, const py::object& eta,
         double length_scale, const std::string& device, py::object progress) -> py::object {
        const bool translucent = material == "subsurface";
        check_device_arg(device, basis == "wavelet" ? prt::TransferKind::Wavelet : prt::TransferKind::SH, material);
        check_subsurface_given(material, sss, sigma_a, sigma_s, eta, length_scale);
        if (translucent) check_subsurface_args(basis, mode, albedo, vertex_colors, !adaptive.is_none(), light_bounce);
        if (basis != "sh" && basis != "wavelet")
          throw Error("basis: expected 'sh' or 'wavelet' (for 'zh', fit_zh the SH transfer), got '" + basis + "'");
        const std::optional<prt::AdaptiveOptions> adapt = adaptive_arg(adaptive, verify_adaptive, adaptive_any, samples);
        if (basis == "wavelet") {
          if (light_bounce) throw Error("light_bounce: applies to basis='sh' (an interreflected SH transfer)");
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
          const std::unique_ptr<prt::PointTracer> gpu = device_tracer(device, mesh);  // kept while it traces
          w.tracer = gpu.get();
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
        if (material != "diffuse" && material != "glossy" && !translucent)
          throw Error("material: expected 'diffuse', 'glossy' or 'subsurface', got '" + material + "'");
        o.glossy = material == "glossy";
        PyTransfer p;
        if (translucent) {
          // As prt precompute --material subsurface: the transmitted light's
          // rows traced, then summed by the profile (compute_subsurface_transfer).
          const prt::SubsurfaceRecord r = subsurface_arg(sss, sigma_a, sigma_s, eta, length_scale);
          prt::SubsurfaceScatterOptions so;
          so.length_scale = r.length_scale;
          so.threads = o.threads;
          p.t = run_released(std::move(progress), [&](const prt::Progress& pr) {
            return prt::compute_subsurface_transfer(mesh, o, r.material, so, pr);
          });
          return py::cast(std::move(p));
        }
        light_bounce_args(o, light_bounce, bounce_patch, bounce_ratio, bounce_clusters, bounce_probes);
        p.t = run_released(std::move(progress), [&](const prt::Progress& pr) {
          const std::unique_ptr<prt::PointTracer> gpu = device_tracer(device, mesh);  // kept while it traces
          o.tracer = gpu.get();
          return adapt ? prt::compute_adaptive_transfer(mesh, o, *adapt, pr) : prt::compute_transfer(mesh, o, pr);
        });
        return py::cast(std::move(p));
      },
      py::arg("mesh"), py::kw_only(), py::arg("bands") = py::none(), py::arg("samples") = 1024,
      py::arg("mode") = "shadowed", py::arg("bounces") = 1, py::arg("albedo") = 0.8, py::arg("vertex_colors") = false,
      py::arg("seed") = 1, py::arg("threads") = 0, py::arg("offset") = 0.0, py::arg("bounce_tolerance") = 0.0,
      py::arg("material") = "diffuse", py::arg("basis") = "sh", py::arg("cube_res") = 32, py::arg("threshold") = 1e-2,
      py::arg("adaptive") = py::none(), py::arg("verify_adaptive") = 0.0, py::arg("adaptive_any") = false,
      py::arg("light_bounce") = false, py::arg("bounce_patch") = 0.0, py::arg("bounce_ratio") = prt::kLightBounceRatio,
      py::arg("bounce_clusters") = prt::kLightBounceClusters, py::arg("bounce_probes") = py::none(),
      py::arg("sss") = py::none(), py::arg("sigma_a") = py::none(), py::arg("sigma_s") = py::none(),
      py::arg("eta") = py::none(), py::arg("length_scale") = kDefaultLengthScale, py::arg("device") = "cpu",
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
      "  material: 'diffuse'; 'glossy': also the transfer matrices of glossy PRT (at most 12 bands; docs/GLOSSY.md); or 'subsurface': a translucent material's RGB transfer (the dipole's light under the surface; shadowed or interreflected, SH, no albedo, adaptive or light_bounce; docs/SUBSURFACE.md) [--material].\n"
      "  sss: material='subsurface': a measured material of Jensen et al. 2001 by D3DX's name ('marble', 'skin1', ...); sigma_a, sigma_s, eta override its values [--sss].\n"
      "  sigma_a, sigma_s: material='subsurface': the absorption and reduced scattering coefficients (r, g, b) in 1/mm, both without sss [--sigma-a, --sigma-s].\n"
      "  eta: material='subsurface': the relative index of refraction, 1 to 3 (None: the preset's; 1.3 with sigma_a and sigma_s) [--eta].\n"
      "  length_scale: material='subsurface': millimetres per mesh unit (25, D3DX's samples' fLengthScale) [--length-scale].\n"
      "  basis: 'sh'; or 'wavelet': a WaveletTransfer (shadowed, diffuse; samples, seed and bounces do not apply: one ray per cube texel) [--basis].\n"
      "  cube_res: wavelet basis: the cube's face size r, a power of two 2 to 256 (32) [--cube-res].\n"
      "  threshold: wavelet basis: the relative L2 error each vertex's kept coefficients may leave, [0, 1) (0.01) [--threshold].\n"
      "  adaptive: adaptive sample points (basis='sh'; docs/PRECOMPUTE.md): None traces every vertex; a tolerance TOL in (0, 1) traces a subset and interpolates the rest along the surface where probes show interpolation adds at most TOL (relative RMS, band-weighted); 0: the default TOL, 0.01, and 0.01 x sqrt(1024 / samples) past 1024 samples [--adaptive [TOL]: 0 is the option without a value]. The Transfer's .interpolated marks the interpolated vertices.\n"
      "  verify_adaptive: with adaptive: trace this fraction, [0, 1], of the interpolated vertices again (they keep the traced transfer) (0) [--verify-adaptive].\n"
      "  adaptive_any: with adaptive: take a TOL above 1.5x the default, which is refused otherwise [--adaptive-any].\n"
      "  light_bounce: with mode='interreflected', keep the bounces' gather as the lights' bounce operator (Transfer.light_bounce; relight(lights=...) and render apply it; docs/LIGHTS.md \"Bounce\") [--light-bounce].\n"
      "  bounce_patch, bounce_ratio, bounce_clusters: its finest patches' size in mesh units (0: a few vertices' spacing), how coarse a far patch may be against its distance (1), the levels a far link's receiving cluster stays below its source (2; -1: none) [--bounce-patch, --bounce-ratio, --bounce-clusters].\n"
      "  bounce_probes: (NX, NY, NZ): the operator's rows for that probe grid's probes too, which the probe-lit object of render(probes=, object=) takes (None: none) [--probes with --light-bounce].\n"
      "  device: 'cpu' (Embree on every core) or 'gpu': the rays of an SH transfer (shadowed, interreflected, glossy) or a wavelet transfer in OpenGL compute over a BVH built here (adaptive too; not material='subsurface'; prt.Error where no OpenGL 4.5 context can be made; docs/PRECOMPUTE.md \"On the GPU\") [--device].\n"
      "  progress: None, True (a line on stderr) or a callable (done, total, phase) returning False to stop; Ctrl-C stops it (KeyboardInterrupt).\n"
      "\n"
      "Returns a Transfer (a WaveletTransfer for basis='wavelet'; for material='subsurface' an RGB one whose .subsurface records the material).");
}

}  // namespace prt::python
